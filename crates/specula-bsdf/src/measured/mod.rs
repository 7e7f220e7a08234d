pub mod merl;
pub mod rgl;

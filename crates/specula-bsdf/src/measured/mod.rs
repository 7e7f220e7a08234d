pub mod fit;
pub mod merl;
pub mod rgl;

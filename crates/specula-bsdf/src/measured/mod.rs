pub mod rgl;

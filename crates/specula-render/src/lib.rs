//! # specula-render
//!
//! Specula's path tracer. Reads Mitsuba 3 XML scenes unchanged, renders them with
//! unidirectional path tracing (next-event estimation, multiple importance sampling, Russian
//! roulette) over a BVH, and writes OpenEXR and PNG.
//!
//! Layout:
//! - [`core`]: rays, hits, surface geometry, errors;
//! - [`xml`]: the Mitsuba 3 XML reader (a generic plugin tree with resolved defaults,
//!   parameters, includes, transforms);
//! - [`geometry`], [`mesh_io`], [`accel`]: shapes, OBJ/PLY loading, the BVH;
//! - [`emitters`], [`texture`], [`image_io`], [`film`]: lights, textures, images, the film;
//! - [`scene`], [`camera`], [`integrator`], [`render`]: assembling and rendering a scene;
//!   [`adaptive`]: rendering with the samples spent where the image is noisy.

pub mod accel;
pub mod adaptive;
pub mod camera;
pub mod core;
pub mod emitters;
pub mod film;
pub mod geometry;
pub mod image_io;
pub mod integrator;
pub mod media;
pub mod mesh_io;
pub mod metrics;
pub mod prefetch;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod serialized;
pub mod spectral;
pub mod texture;
pub mod timings;
pub mod volpath;
pub mod xml;

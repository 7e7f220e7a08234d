//! Mitsuba's `shapegroup` and `instance`.
//!
//! **Instance** (`shapegroup` + `instance`): a [`ShapeGroup`] holds its shapes in the
//! group's own space, their BSDFs and one BVH over them, shared (`Arc`) by every instance.
//! An instance of a group of k shapes occupies k consecutive scene shape slots (one per
//! group shape, so that a hit's shape index names the right BSDF), of which only the first
//! is put in the scene's BVH: one primitive whose box is the transformed group box and
//! whose intersection carries the ray into the group's BVH. The surface is the group
//! shape's, carried to world space: `p`, ∂p/∂u and ∂p/∂v by `to_world`, the normals by its
//! inverse transpose, `s` from the world ∂p/∂u (as Mitsuba's `instance`); `mesh_attribute`
//! reads the group shape's attributes. Instances cannot emit (Mitsuba forbids emitters in
//! shape groups) and are never sampled by area (area 0, like Mitsuba's, which does not
//! implement it). An instance costs one `Geometry` (a few hundred bytes) per group shape
//! and one primitive in the scene's BVH; the group's meshes and BVH exist once.

use super::*;

/// Mitsuba's `shapegroup`: shapes in the group's own space with their scene BSDF indices, and
/// one BVH over them that every [`Instance`] of the group shares.
#[derive(Debug)]
pub struct ShapeGroup {
    pub shapes: Vec<Geometry>,
    /// Scene BSDF index of each shape.
    pub bsdfs: Vec<u32>,
    pub accel: crate::accel::Bvh,
    /// Bounds of the group's shapes (min, max); empty (min > max) for an empty group.
    pub(super) bounds: (Vec3, Vec3),
}

impl ShapeGroup {
    /// A group of `shapes` (which must not be instances) with their scene BSDF indices.
    pub fn new(shapes: Vec<Geometry>, bsdfs: Vec<u32>) -> ShapeGroup {
        let accel = crate::accel::Bvh::build(&shapes);
        let bounds = shapes
            .iter()
            .map(Geometry::bounds)
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (a, b)| {
                (lo.min(a), hi.max(b))
            });
        ShapeGroup {
            shapes,
            bsdfs,
            accel,
            bounds,
        }
    }
}

/// One scene slot of an instance of a [`ShapeGroup`]: it stands for the group's shape
/// `member`; the slot of member 0 is the one in the scene's BVH (see the module docs).
#[derive(Clone, Debug)]
pub struct Instance {
    pub group: Arc<ShapeGroup>,
    pub member: u32,
    pub to_world: Mat4,
    pub to_object: Mat4,
    /// `to_world`'s inverse transpose (3×3).
    pub(super) nm: Mat3,
}

impl Instance {
    /// Not sampled (instances cannot emit): a point of the group shape carried to world
    /// space, density 0.
    #[inline(never)]
    pub(super) fn sample_position(&self, u: Vec2) -> PositionSample {
        let ps = self.group.shapes[self.member as usize].sample_position(u);
        PositionSample {
            p: self.to_world.transform_point3(ps.p),
            n: (self.nm * ps.n).normalize_or(ps.n),
            uv: ps.uv,
            pdf: 0.0,
        }
    }

    /// The group shape's surface at the hit, carried to world space.
    #[inline(never)]
    pub(super) fn surface(&self, ray: &Ray, hit: &Hit) -> SurfaceGeometry {
        let local_ray = Ray {
            o: self.to_object.transform_point3(ray.o),
            d: self.to_object.transform_vector3(ray.d),
            t_max: ray.t_max,
        };
        let inner = Hit {
            t: hit.t,
            shape: self.member,
            prim: hit.prim,
            u: hit.u,
            v: hit.v,
            vertices: None,
        };
        let s = self.group.shapes[self.member as usize].surface(&local_ray, &inner);
        let n_geo = (self.nm * s.n_geo).normalize_or(s.n_geo);
        let n = (self.nm * s.sh_frame.n).normalize_or(n_geo);
        let dp_du = self.to_world.transform_vector3(s.dp_du);
        // s from the world ∂p/∂u, as Mitsuba; the group shape's own s where ∂p/∂u vanishes
        let s_dir = if dp_du == Vec3::ZERO {
            self.to_world.transform_vector3(s.sh_frame.s)
        } else {
            dp_du
        };
        SurfaceGeometry {
            p: self.to_world.transform_point3(s.p),
            n_geo,
            sh_frame: shading_frame(n, s_dir),
            uv: s.uv,
            dp_du,
            dp_dv: self.to_world.transform_vector3(s.dp_dv),
        }
    }

    /// World-space bounds of the whole group (the transformed corners of its box).
    pub(super) fn bounds(&self) -> (Vec3, Vec3) {
        let (lo, hi) = self.group.bounds;
        if !(lo.cmple(hi).all()) {
            return (lo, hi);
        }
        (0..8).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), i| {
            let c = Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            let p = self.to_world.transform_point3(c);
            (a.min(p), b.max(p))
        })
    }
}

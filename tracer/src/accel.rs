//! Ray queries: the world-space triangles of every instance in an obvhs BVH, the watertight
//! ray–triangle test, robust self-intersection offsets and the surface at a hit.
//!
//! - **BVH**: obvhs 0.4's 8-wide compressed `CwBvh`. Its traversal misses every hit when a
//!   direction component is `-0.0` (DESIGN §10), so every direction is canonicalized with
//!   `d + Vec3A::ZERO` (which turns `-0.0` into `+0.0`) before it reaches obvhs; a test keeps
//!   that honest.
//! - **Triangles**: the watertight test of Woop, Benthin and Wald (JCGT 2013): the ray is
//!   sheared so it runs along +z, the edge functions are evaluated in 2D, and where one is
//!   exactly zero it is recomputed in f64, so a ray through a shared edge or vertex hits at
//!   least one of its triangles and never slips between them.
//! - **Offsets**: Wächter and Binder, *A Fast and Robust Method for Avoiding
//!   Self-Intersection* (Ray Tracing Gems, ch. 6): a secondary ray starts at the hit point
//!   moved a few ulps along the geometric normal (integer steps in the float's bit pattern,
//!   a fixed step near the origin), so the offset scales with the coordinates' magnitude and
//!   rays start at `t = 0`. The hit point is computed from barycentrics, not from `o + t·d`,
//!   which keeps it within a few ulps of the surface.

use crate::geometry::{MAX_COORDINATE, Mesh, interpolate};
use crate::scene::Instance;
use glam::{DVec3, Vec2, Vec3, Vec3A};
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use std::collections::HashSet;

/// Per-triangle shading attributes, world space.
#[derive(Clone, Copy, Debug)]
struct TriAttr {
    normals: Option<[Vec3; 3]>,
    uvs: [Vec2; 3],
    instance: u32,
    /// The mesh's vertex indices (wound as placed): where named attributes are read.
    verts: [u32; 3],
}

/// The world's triangles and their BVH.
pub struct Accel {
    bvh: Option<CwBvh>,
    tris: Vec<Triangle>,
    attrs: Vec<TriAttr>,
    /// The first instance with triangles left out of the BVH, and how many in all.
    rejected: Option<(u32, usize)>,
}

impl std::fmt::Debug for Accel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Accel")
            .field("triangles", &self.tris.len())
            .finish()
    }
}

/// A ray's closest hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) direction.
    pub t: f32,
    /// Triangle index.
    pub prim: u32,
    /// Barycentric weights of the triangle's three vertices.
    pub bary: [f32; 3],
}

/// The surface at a hit: what the tracer turns into a shading fragment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// The point, from barycentrics.
    pub p: Vec3,
    /// Unit geometric normal, by the triangle's winding (not flipped towards the ray).
    pub ng: Vec3,
    /// Unit shading normal: interpolated vertex normals, or `ng` (not flipped).
    pub n: Vec3,
    /// Surface parameters (when asked for).
    pub uv: Vec2,
    /// ∂P/∂u (when asked for).
    pub dpdu: Vec3,
    /// ∂P/∂v (when asked for).
    pub dpdv: Vec3,
    /// Index into the scene's instances.
    pub instance: u32,
}

/// Whether obvhs can hold a vertex: finite and within ±[`MAX_COORDINATE`].
fn in_range(p: Vec3) -> bool {
    p.is_finite() && f64::from(p.abs().max_element()) <= MAX_COORDINATE
}

/// Moves `p` off the surface with unit geometric normal `n`, to the side `n` points to
/// (Wächter and Binder 2019).
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let step = |p: f32, n: f32| -> f32 {
        if p.abs() < ORIGIN {
            return p + FLOAT_SCALE * n;
        }
        let of = (INT_SCALE * n) as i32;
        let bits = p.to_bits() as i32;
        let moved = if p < 0.0 {
            bits.wrapping_sub(of)
        } else {
            bits.wrapping_add(of)
        };
        let r = f32::from_bits(moved as u32);
        if r.is_finite() { r } else { p }
    };
    Vec3::new(step(p.x, n.x), step(p.y, n.y), step(p.z, n.z))
}

/// A direction obvhs can traverse: `-0.0` components become `+0.0` (DESIGN §10).
pub fn canonical(d: Vec3) -> Vec3A {
    Vec3A::from(d) + Vec3A::ZERO
}

/// A ray prepared for the watertight test: the axis permutation and shear.
#[derive(Clone, Copy, Debug)]
struct Sheared {
    org: Vec3A,
    k: [usize; 3],
    s: [f32; 3],
}

impl Sheared {
    fn new(org: Vec3A, dir: Vec3A) -> Sheared {
        let a = dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Sheared {
            org,
            k: [kx, ky, kz],
            s: [dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]],
        }
    }

    /// `(t, barycentrics)` of a hit with `t` in `(tmin, tmax)`.
    fn intersect(&self, tri: &Triangle, tmin: f32, tmax: f32) -> Option<(f32, [f32; 3])> {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.s;
        let a = tri.v0 - self.org;
        let b = tri.v1 - self.org;
        let c = tri.v2 - self.org;
        let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
        let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let f = |x: f32| x as f64;
            u = (f(cx) * f(by) - f(cy) * f(bx)) as f32;
            v = (f(ax) * f(cy) - f(ay) * f(cx)) as f32;
            w = (f(bx) * f(ay) - f(by) * f(ax)) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let (az, bz, cz) = (sz * a[kz], sz * b[kz], sz * c[kz]);
        let t = (u * az + v * bz + w * cz) / det;
        if !(t > tmin && t < tmax) {
            return None;
        }
        Some((t, [u / det, v / det, w / det]))
    }
}

impl Accel {
    /// Transforms every instance's mesh into world space and builds the BVH of the
    /// triangles it can hold ([`Accel::rejected`] reports the others).
    pub fn build(meshes: &[Mesh], instances: &[Instance]) -> Accel {
        let mut tris = Vec::new();
        let mut attrs = Vec::new();
        let mut rejected = None;
        // Exact copies of a triangle already placed (the same three world-space vertices):
        // many of them in one place make obvhs build a BVH deeper than its traversal stack,
        // which drops hits (docs/obvhs-defect.md §3). A copy can never be the only closest
        // hit, so the first placed (lowest instance index) is kept: a deterministic choice
        // among coincident surfaces.
        let mut placed: HashSet<[[u32; 3]; 3]> = HashSet::new();
        for (ii, inst) in instances.iter().enumerate() {
            let Some(mesh) = meshes.get(inst.mesh) else {
                continue;
            };
            let m = inst.transform;
            let nm = m.inverse().transpose();
            let flip = m.determinant() < 0.0;
            let pos: Vec<Vec3> = mesh
                .positions
                .iter()
                .map(|p| m.transform_point3(DVec3::from(p.map(f64::from))).as_vec3())
                .collect();
            let nrm: Option<Vec<Vec3>> = mesh.normals.as_ref().map(|ns| {
                ns.iter()
                    .map(|n| {
                        nm.transform_vector3(DVec3::from(n.map(f64::from)))
                            .normalize_or_zero()
                            .as_vec3()
                    })
                    .collect()
            });
            for t in &mesh.triangles {
                // A mirroring transform reverses the winding: swap to keep the front.
                let t = if flip { [t[0], t[2], t[1]] } else { *t };
                let [i0, i1, i2] = t.map(|i| i as usize);
                // The BVH never sees what it cannot hold (docs/obvhs-defect.md): a vertex
                // that is not finite or lies beyond the supported range is left out and
                // reported (a loaded scene has been checked: this only guards scenes built
                // by hand).
                if ![i0, i1, i2].iter().all(|&i| in_range(pos[i])) {
                    let r = rejected.get_or_insert((ii as u32, 0));
                    r.1 += 1;
                    continue;
                }
                // A triangle without area cannot be hit (the watertight test finds a zero
                // determinant), and many of them in one place make obvhs build a BVH deeper
                // than its traversal stack (docs/obvhs-defect.md): leave them out.
                let [a, b, c] = [i0, i1, i2].map(|i| pos[i].as_dvec3());
                if (b - a).cross(c - a) == DVec3::ZERO {
                    continue;
                }
                let mut key = [i0, i1, i2].map(|i| pos[i].to_array().map(f32::to_bits));
                key.sort_unstable();
                if !placed.insert(key) {
                    continue;
                }
                tris.push(Triangle {
                    v0: pos[i0].into(),
                    v1: pos[i1].into(),
                    v2: pos[i2].into(),
                });
                attrs.push(TriAttr {
                    normals: nrm.as_ref().map(|n| [n[i0], n[i1], n[i2]]),
                    uvs: match &mesh.uvs {
                        Some(uv) => [i0, i1, i2].map(|i| Vec2::from(uv[i])),
                        None => [Vec2::ZERO, Vec2::X, Vec2::ONE],
                    },
                    instance: ii as u32,
                    verts: t,
                });
            }
        }
        let bvh = (!tris.is_empty()).then(|| {
            obvhs::cwbvh::builder::build_cwbvh_from_tris(
                &tris,
                obvhs::BvhBuildParams::medium_build(),
                &mut std::time::Duration::default(),
            )
        });
        Accel {
            bvh,
            tris,
            attrs,
            rejected,
        }
    }

    /// Triangles [`Accel::build`] left out because a vertex was not finite or lay beyond
    /// [`MAX_COORDINATE`] after its transform: the first such instance's index and the
    /// count over all instances; `None` when every triangle is in the BVH.
    pub fn rejected(&self) -> Option<(u32, usize)> {
        self.rejected
    }

    /// The mesh vertex indices of a triangle (as wound in the world), for named attributes.
    pub fn vertices(&self, prim: u32) -> [u32; 3] {
        self.attrs.get(prim as usize).map_or([0; 3], |a| a.verts)
    }

    /// The instance a triangle belongs to.
    pub fn instance(&self, prim: u32) -> u32 {
        self.attrs.get(prim as usize).map_or(0, |a| a.instance)
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// The closest hit along `o + t·d`, `0 < t < tmax` (`d` unit).
    pub fn closest(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let (org, dir) = (Vec3A::from(o), canonical(d));
        let sheared = Sheared::new(org, dir);
        let ray = Ray::new(org, dir, 0.0, tmax);
        let mut hit = RayHit::none();
        let found = bvh.ray_traverse(ray, &mut hit, |r, id| {
            let prim = bvh.primitive_indices[id] as usize;
            sheared
                .intersect(&self.tris[prim], r.tmin, r.tmax)
                .map_or(f32::INFINITY, |(t, _)| t)
        });
        if !found {
            return None;
        }
        let prim = bvh.primitive_indices[hit.primitive_id as usize];
        // Recompute the barycentrics of the winner (traversal only keeps t).
        let (t, bary) = sheared.intersect(&self.tris[prim as usize], 0.0, f32::INFINITY)?;
        Some(Hit { t, prim, bary })
    }

    /// Whether anything lies along `o + t·d`, `0 < t < tmax`.
    pub fn occluded(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        let (org, dir) = (Vec3A::from(o), canonical(d));
        let sheared = Sheared::new(org, dir);
        let ray = Ray::new(org, dir, 0.0, tmax);
        !bvh.ray_traverse_miss(ray, |r, id| {
            let prim = bvh.primitive_indices[id] as usize;
            sheared
                .intersect(&self.tris[prim], r.tmin, r.tmax)
                .map_or(f32::INFINITY, |(t, _)| t)
        })
    }

    /// The surface at a hit; uv and tangents only when `uv_tangents` (needs say so).
    pub fn surface(&self, hit: &Hit, uv_tangents: bool) -> Surface {
        let tri = &self.tris[hit.prim as usize];
        let attr = &self.attrs[hit.prim as usize];
        let [b0, b1, b2] = hit.bary;
        let (p0, p1, p2) = (Vec3::from(tri.v0), Vec3::from(tri.v1), Vec3::from(tri.v2));
        let p = p0 * b0 + p1 * b1 + p2 * b2;
        let ng = (p1 - p0).cross(p2 - p0).normalize_or_zero();
        let n = match attr.normals {
            Some(ns) => {
                let n =
                    Vec3::from(interpolate(ns.map(|n| n.to_array()), hit.bary)).normalize_or_zero();
                if n == Vec3::ZERO { ng } else { n }
            }
            None => ng,
        };
        let mut s = Surface {
            p,
            ng,
            n,
            uv: Vec2::ZERO,
            dpdu: Vec3::ZERO,
            dpdv: Vec3::ZERO,
            instance: attr.instance,
        };
        if uv_tangents {
            let [t0, t1, t2] = attr.uvs;
            s.uv = Vec2::from(interpolate(attr.uvs.map(|t| t.to_array()), hit.bary));
            // pbrt's triangle tangents: solve dp02 = du02·dpdu + dv02·dpdv (and for 12).
            let (d02, d12) = (t0 - t2, t1 - t2);
            let (dp02, dp12) = (p0 - p2, p1 - p2);
            let det = d02.x * d12.y - d02.y * d12.x;
            let (dpdu, dpdv) = if det.abs() < 1e-12 {
                orthonormal(ng)
            } else {
                let inv = 1.0 / det;
                (
                    (dp02 * d12.y - dp12 * d02.y) * inv,
                    (dp12 * d02.x - dp02 * d12.x) * inv,
                )
            };
            s.dpdu = dpdu;
            s.dpdv = dpdv;
        }
        s
    }
}

/// Two unit vectors completing `n` to an orthonormal basis (Duff et al. 2017).
pub fn orthonormal(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{unit_box, unit_quad, unit_sphere};
    use glam::DMat4;

    fn scene(mesh: Mesh, m: DMat4) -> Accel {
        Accel::build(
            &[mesh],
            &[Instance {
                name: "x".into(),
                mesh: 0,
                material: 0,
                transform: m,
                geomprops: Default::default(),
            }],
        )
    }

    /// obvhs 0.4's CwBvh misses rays with a `-0.0` direction component (DESIGN §10): ours
    /// canonicalize them.
    #[test]
    fn negative_zero_direction_components_still_hit() {
        let a = scene(unit_quad(), DMat4::IDENTITY);
        for d in [
            Vec3::new(-0.0, 0.0, -1.0),
            Vec3::new(0.0, -0.0, -1.0),
            Vec3::new(-0.0, -0.0, -1.0),
        ] {
            let h = a
                .closest(Vec3::new(0.1, 0.2, 1.0), d, f32::INFINITY)
                .unwrap_or_else(|| panic!("direction {d:?} missed"));
            assert!((h.t - 1.0).abs() < 1e-6);
            assert!(a.occluded(Vec3::new(0.1, 0.2, 1.0), d, 2.0));
        }
        // And from below, along -0.0 in x and y with +z.
        assert!(
            a.closest(Vec3::new(0.3, -0.3, -2.0), Vec3::new(-0.0, -0.0, 1.0), 10.0)
                .is_some()
        );
    }

    /// Rays through the shared diagonal of the quad's two triangles and through its shared
    /// vertices never slip between them.
    #[test]
    fn watertight_on_shared_edges() {
        let a = scene(unit_quad(), DMat4::IDENTITY);
        for i in 0..=200 {
            let s = -1.0 + 2.0 * i as f32 / 200.0;
            // The diagonal from (-1,-1) to (1,1), slightly inside the quad's border.
            let p = Vec3::new(s * 0.999, s * 0.999, 3.0);
            let d = (Vec3::new(0.0, 0.0, 0.0) - Vec3::new(0.0, 0.0, 3.0)).normalize();
            assert!(
                a.closest(p, d, f32::INFINITY).is_some(),
                "slipped at s = {s}"
            );
            // Oblique rays aimed at diagonal points.
            let target = Vec3::new(s * 0.999, s * 0.999, 0.0);
            let o = Vec3::new(0.37, -1.3, 2.1);
            assert!(
                a.closest(o, (target - o).normalize(), f32::INFINITY)
                    .is_some(),
                "oblique ray slipped at s = {s}"
            );
        }
        // The center vertex of the box faces' fan: every face of the box is hit at its
        // center from outside.
        let b = scene(unit_box(), DMat4::IDENTITY);
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let mut o = Vec3::ZERO;
                o[axis] = 5.0 * sign;
                let h = b.closest(o, -o.normalize(), f32::INFINITY).expect("face");
                assert!((h.t - 4.0).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn offsets_leave_the_surface_at_any_scale() {
        for scale in [1e-3f64, 1.0, 1e3, 1e5] {
            let m = DMat4::from_scale(DVec3::splat(scale))
                * DMat4::from_rotation_x(0.3)
                * DMat4::from_rotation_y(0.7);
            let a = scene(unit_sphere(32), m);
            let mut self_hits = 0;
            for i in 0..200 {
                let f = i as f32 / 200.0;
                let o = Vec3::new(3.0 * scale as f32, (f - 0.5) * scale as f32, 0.2);
                let d = (Vec3::new(0.0, (f - 0.5) * 0.3, 0.0) * scale as f32 - o).normalize();
                let Some(h) = a.closest(o, d, f32::INFINITY) else {
                    continue;
                };
                let s = a.surface(&h, false);
                // Leave outward (towards the camera side): nothing may be hit right away.
                let ng = if s.ng.dot(d) < 0.0 { s.ng } else { -s.ng };
                let p = offset_origin(s.p, ng);
                let out = (d - 2.0 * d.dot(s.n) * s.n).normalize();
                if let Some(h2) = a.closest(p, out, f32::INFINITY)
                    && h2.t < 1e-3 * scale as f32
                {
                    self_hits += 1;
                }
                // A shadow ray back towards the ray origin is unblocked.
                if a.occluded(p, (o - p).normalize(), (o - p).length()) {
                    self_hits += 1;
                }
            }
            assert_eq!(self_hits, 0, "scale {scale}");
        }
    }

    #[test]
    fn sphere_is_wound_outward_and_closed() {
        let m = unit_sphere(16);
        for t in &m.triangles {
            let p = t.map(|i| Vec3::from(m.positions[i as usize]));
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let c = (p[0] + p[1] + p[2]) / 3.0;
            assert!(n.dot(c) > 0.0, "triangle {t:?} faces inward");
        }
        let a = scene(m, DMat4::IDENTITY);
        // Rays from the center escape nowhere.
        for i in 0..500 {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 500.0;
            let r = (1.0 - z * z).sqrt();
            let phi = i as f32 * 2.399_963;
            let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            assert!(
                a.closest(Vec3::ZERO, d, f32::INFINITY).is_some(),
                "escaped along {d:?}"
            );
        }
    }
}

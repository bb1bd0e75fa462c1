//! Fixtures for the back ends' parity tests (the root crate's `tests/backends.rs`, the GPU
//! crate's tests): inputs that reach the corners of the numeric rules, and a scene whose
//! answers depend on every bit of every argument.
//!
//! Owns nothing a renderer uses; must not depend on a back end.

use crate::ctx::{SceneServices, ShadeEnv, Transform};
use shadenet_graph::nodes::{LightDesc, LightKind};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Ordinary and hard floats: zeros of both signs, denormals, the smallest normal, tiny and
/// huge values, the extremes, infinities, NaN, values next to 1 and around 2²⁴.
pub const HARD_FLOATS: &[f32] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    -2.5,
    3.0,
    0.1,
    1.5,
    100.25,
    -7.75,
    std::f32::consts::PI,
    1e-45,             // smallest denormal
    -3e-41,            // a negative denormal
    f32::MIN_POSITIVE, // smallest normal
    1e-30,             // tiny
    1e30,              // huge
    -1e30,
    f32::MAX,
    f32::MIN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    1e-7,       // grazing
    0.99999994, // just below 1
    1.0000001,  // just above 1
    16777216.0, // 2^24
    -16777217.0,
];

/// The parity environment: point, ambient, distant, spot, quad (5 samples) and environment
/// (3 samples) lights, a look-at camera and a skewed object transform.
pub fn parity_env() -> ShadeEnv {
    let light = |name: &str, kind, power| LightDesc::new(name, kind, power).expect("a valid light");
    let lights = [
        light(
            "key",
            LightKind::Point {
                position: [1.0, 1.0, 2.0],
            },
            [20.0, 18.0, 15.0],
        ),
        light("fill", LightKind::Ambient, [0.1, 0.2, 0.3]),
        light(
            "sun",
            LightKind::Distant {
                direction: [0.3, -0.5, -0.8],
            },
            [1.5, 1.5, 1.2],
        ),
        light(
            "spot",
            LightKind::Spot {
                position: [0.0, 0.0, 3.0],
                direction: [0.0, 0.0, -1.0],
                cone_angle: 0.8,
                penumbra_angle: 0.1,
                dropoff: 2.0,
            },
            [30.0, 30.0, 30.0],
        ),
        light(
            "quad",
            LightKind::Quad {
                corner: [-1.0, -1.0, 2.0],
                edge_u: [0.0, 2.0, 0.0],
                edge_v: [2.0, 0.0, 0.0],
                samples: 5,
            },
            [1.5; 3],
        ),
        light(
            "sky",
            LightKind::Environment {
                samples: 3,
                map: None,
            },
            [0.2, 0.3, 0.5],
        ),
    ];
    let mut env = ShadeEnv::with_lights(&lights);
    env.camera = Transform::look_at([0.5, 0.2, 1.5], [0.0; 3], [0.0, 1.0, 0.0]).expect("camera");
    env.object = Transform::new([
        2.0, 0.0, 0.0, 0.5, //
        0.0, 0.5, 0.1, -1.0, //
        0.0, 0.0, 1.0, 0.25, //
        0.0, 0.0, 0.0, 1.0,
    ])
    .expect("object");
    env
}

/// Ordinary and extreme ints.
pub const HARD_INTS: &[i32] = &[0, 1, -1, 2, -2, 7, -7, 31, 100, -100, i32::MAX, i32::MIN];

/// A scene whose every answer is a hash of all its arguments' bits (so any argument a back
/// end passes differently shows), with out-of-range and NaN occlusion answers; it counts its
/// calls. A smooth one ([`HashScene::new`]) answers `trace` and `occlusion` with smooth functions of
/// their arguments instead, for back ends held to a tolerance (a hardware GPU's directions
/// differ from the CPU's by ulps, which a hash turns into unrelated answers).
#[derive(Debug, Default)]
pub struct HashScene {
    calls: AtomicUsize,
    smooth: bool,
}

impl HashScene {
    /// The scene, with smooth `trace` and `occlusion` answers where `smooth` (shadow rays
    /// still hashed: their end points come from the host's light samples, the same bits on
    /// every back end); `HashScene::default()` is `new(false)`.
    pub fn new(smooth: bool) -> HashScene {
        HashScene {
            calls: AtomicUsize::new(0),
            smooth,
        }
    }

    fn hash(&self, xs: impl IntoIterator<Item = u32>) -> u64 {
        self.calls.fetch_add(1, Ordering::Relaxed);
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        for x in xs {
            h = (h ^ x as u64).wrapping_mul(0x0100_0000_01b3);
        }
        h ^ (h >> 29)
    }

    /// How many questions it has answered.
    pub fn calls(&self) -> usize {
        self.calls.load(Ordering::Relaxed)
    }
}

fn unit(h: u64, k: u32) -> f32 {
    ((h >> (k * 16)) & 0xffff) as f32 / 65536.0
}

fn bits(v: [f32; 3]) -> [u32; 3] {
    v.map(f32::to_bits)
}

impl SceneServices for HashScene {
    fn trace(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        ray_type: i32,
        depth: i32,
        bsdf_pdf: f32,
    ) -> [f32; 3] {
        if self.smooth {
            self.calls.fetch_add(1, Ordering::Relaxed);
            let k =
                1.0 + 0.01 * ray_type as f32 + 0.1 * depth as f32 + 0.5 / (1.0 + bsdf_pdf.abs());
            let o = 0.05 * (origin[0] + origin[1] + origin[2]);
            return std::array::from_fn(|c| k * (1.0 + 0.5 * dir[c] + o));
        }
        let h = self.hash(bits(origin).into_iter().chain(bits(dir)).chain([
            ray_type as u32,
            depth as u32,
            bsdf_pdf.to_bits(),
        ]));
        [2.0 * unit(h, 0), 2.0 * unit(h, 1), 2.0 * unit(h, 2)]
    }

    fn occluded(&self, from: [f32; 3], to: [f32; 3]) -> bool {
        self.hash(bits(from).into_iter().chain(bits(to))) & 1 == 1
    }

    fn occlusion(&self, p: [f32; 3], n: [f32; 3], samples: u32, max: f32, seed: u32) -> f32 {
        if self.smooth {
            self.calls.fetch_add(1, Ordering::Relaxed);
            let x = 0.5 + 0.2 * n[0] + 0.1 * n[2] + 0.05 * p[1] + 0.01 * (samples % 7) as f32;
            return (x * max.clamp(0.0, 1.0)).clamp(0.0, 1.0);
        }
        let h = self.hash(
            bits(p)
                .into_iter()
                .chain(bits(n))
                .chain([samples, max.to_bits(), seed]),
        );
        match h % 8 {
            0 => f32::NAN,
            1 => -0.5,
            2 => 1.5,
            _ => unit(h, 1),
        }
    }
}

/// Services that answer with a tag, to tell whose services a question reached: a batch's own
/// (tag −1) or fragment `i`'s (tag `i`, given by [`SceneServices::fragment`]). A trace returns
/// `[tag, 0.5, 0.25]`, occlusion `tag / 1000`, and a shadow ray is blocked for the batch's
/// own services and for the fragments with `i % 3 == 1`.
pub struct TaggedScene {
    /// This level's tag.
    pub tag: f32,
    /// The fragments' own services.
    pub parts: Vec<TaggedScene>,
}

impl TaggedScene {
    /// The batch's services (tag −1) with `n` fragments' own (tags `0 .. n`).
    pub fn with_fragments(n: usize) -> TaggedScene {
        TaggedScene {
            tag: -1.0,
            parts: (0..n)
                .map(|i| TaggedScene {
                    tag: i as f32,
                    parts: Vec::new(),
                })
                .collect(),
        }
    }
}

impl SceneServices for TaggedScene {
    fn trace(&self, _: [f32; 3], _: [f32; 3], _: i32, _: i32, _: f32) -> [f32; 3] {
        [self.tag, 0.5, 0.25]
    }
    fn occluded(&self, _: [f32; 3], _: [f32; 3]) -> bool {
        self.tag < 0.0 || self.tag as u32 % 3 == 1
    }
    fn occlusion(&self, _: [f32; 3], _: [f32; 3], _: u32, _: f32, _: u32) -> f32 {
        self.tag / 1000.0
    }
    /// Fragment `i` (tag ≥ 0) has attribute `slot` where `(i + slot) % 4 != 0`, with
    /// component `k` = `tag / 4 + slot + k / 2`, except that fragments with `i % 7 == 5`
    /// give a NaN first component (which the lookup turns into the default); the batch's
    /// own services have none.
    fn attribute(&self, slot: u32, out: &mut [f32]) -> bool {
        if self.tag < 0.0 || (self.tag as u32 + slot).is_multiple_of(4) {
            return false;
        }
        for (k, o) in out.iter_mut().enumerate() {
            *o = self.tag / 4.0 + slot as f32 + k as f32 / 2.0;
        }
        if self.tag as u32 % 7 == 5 {
            out[0] = f32::NAN;
        }
        true
    }
    fn fragment(&self, index: usize) -> Option<&dyn SceneServices> {
        self.parts.get(index).map(|t| t as &dyn SceneServices)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hash_scene_answers_every_bit_and_counts() {
        let s = HashScene::default();
        let a = s.trace([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0, 0, 0.0);
        assert_ne!(a, s.trace([-0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0, 0, 0.0));
        assert_ne!(a, s.trace([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0, 0, 0.5));
        assert_eq!(a, s.trace([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0, 0, 0.0));
        let occ: Vec<f32> = (0..64)
            .map(|k| s.occlusion([k as f32, 0.0, 0.0], [0.0; 3], 4, 1.0, 0))
            .collect();
        assert!(occ.iter().any(|x| x.is_nan()) && occ.iter().any(|x| *x > 1.0));
        assert_eq!(s.calls(), 68);
    }
}

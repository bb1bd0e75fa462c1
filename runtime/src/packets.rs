//! Fragments in four-lane packets, the layout every batch entry reads and writes.
//!
//! A [`FragmentX4`] holds four fragments as structure of arrays: each stream component as
//! four consecutive lanes, so compiled batch code reads a component of four fragments with
//! one aligned 128-bit load at a constant offset. [`Fragments`] is any number of fragments
//! as consecutive packets (structure of arrays per packet, as OSL's batched shader globals
//! and ISPC lay out their blocks): a batch entry walks the packets with a pointer and
//! constant offsets, and a wider entry reads consecutive packets. The outputs of a batch
//! ([`Material::shade_many`](crate::Material::shade_many)) use the same layout: per packet,
//! output float `k` of its four lanes as four consecutive floats ([`packed_index`]).
//!
//! Owns: the packet types, building them (one fragment at a time, or straight into the
//! packets) and reading them back. Must not touch: shading.

use crate::ctx::Fragment;

/// Lanes of a batch packet: Cranelift's 128-bit vectors hold four f32 (DESIGN §10: F32X4
/// works on x86-64, F32X8 does not).
pub const LANES: usize = 4;

/// Four fragments, structure of arrays: every stream component as four consecutive lanes, so
/// a compiled batch function reads a component of all four fragments with one 128-bit load.
/// `#[repr(C)]` and 16-byte aligned; its field order follows [`Fragment`].
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FragmentX4 {
    /// Shading position, per component.
    pub p: [[f32; LANES]; 3],
    /// Shading normal.
    pub n: [[f32; LANES]; 3],
    /// Geometric normal.
    pub ng: [[f32; LANES]; 3],
    /// Incident direction.
    pub i: [[f32; LANES]; 3],
    /// Surface parameterization.
    pub uv: [[f32; LANES]; 2],
    /// ∂P/∂u.
    pub dpdu: [[f32; LANES]; 3],
    /// ∂P/∂v.
    pub dpdv: [[f32; LANES]; 3],
    /// ∂P/∂x.
    pub dpdx: [[f32; LANES]; 3],
    /// ∂P/∂y.
    pub dpdy: [[f32; LANES]; 3],
    /// Shutter time.
    pub time: [f32; LANES],
    /// Ray type bit.
    pub ray_type: [i32; LANES],
    /// Ray depth.
    pub ray_depth: [i32; LANES],
    /// Sampler seed.
    pub seed: [u32; LANES],
    /// The sampler's four uniform numbers (the `rand` stream), per component.
    pub rand: [[f32; LANES]; 4],
}

impl FragmentX4 {
    /// Packs one to four fragments; missing lanes repeat the last fragment (so that padding
    /// lanes compute something harmless). Panics on an empty slice.
    pub fn gather(frags: &[Fragment]) -> FragmentX4 {
        let mut x = FragmentX4::default();
        let last = frags.len().min(LANES) - 1;
        for lane in 0..LANES {
            x.set_lane(lane, &frags[lane.min(last)]);
        }
        x
    }

    /// Writes fragment `f` into lane `lane`.
    pub fn set_lane(&mut self, lane: usize, f: &Fragment) {
        let put3 = |dst: &mut [[f32; LANES]; 3], v: [f32; 3]| {
            for c in 0..3 {
                dst[c][lane] = v[c];
            }
        };
        put3(&mut self.p, f.p);
        put3(&mut self.n, f.n);
        put3(&mut self.ng, f.ng);
        put3(&mut self.i, f.i);
        self.uv[0][lane] = f.uv[0];
        self.uv[1][lane] = f.uv[1];
        put3(&mut self.dpdu, f.dpdu);
        put3(&mut self.dpdv, f.dpdv);
        put3(&mut self.dpdx, f.dpdx);
        put3(&mut self.dpdy, f.dpdy);
        self.time[lane] = f.time;
        self.ray_type[lane] = f.ray_type;
        self.ray_depth[lane] = f.ray_depth;
        self.seed[lane] = f.seed;
        for c in 0..4 {
            self.rand[c][lane] = f.rand[c];
        }
    }

    /// The fragment in lane `lane`.
    pub fn lane(&self, lane: usize) -> Fragment {
        let get3 = |v: &[[f32; LANES]; 3]| [v[0][lane], v[1][lane], v[2][lane]];
        Fragment {
            p: get3(&self.p),
            n: get3(&self.n),
            ng: get3(&self.ng),
            i: get3(&self.i),
            uv: [self.uv[0][lane], self.uv[1][lane]],
            dpdu: get3(&self.dpdu),
            dpdv: get3(&self.dpdv),
            dpdx: get3(&self.dpdx),
            dpdy: get3(&self.dpdy),
            time: self.time[lane],
            ray_type: self.ray_type[lane],
            ray_depth: self.ray_depth[lane],
            seed: self.seed[lane],
            rand: std::array::from_fn(|c| self.rand[c][lane]),
        }
    }
}

impl FragmentX4 {
    /// A packet whose four lanes are all `f`.
    pub fn splat(f: &Fragment) -> FragmentX4 {
        let s3 = |v: [f32; 3]| v.map(|x| [x; LANES]);
        FragmentX4 {
            p: s3(f.p),
            n: s3(f.n),
            ng: s3(f.ng),
            i: s3(f.i),
            uv: f.uv.map(|x| [x; LANES]),
            dpdu: s3(f.dpdu),
            dpdv: s3(f.dpdv),
            dpdx: s3(f.dpdx),
            dpdy: s3(f.dpdy),
            time: [f.time; LANES],
            ray_type: [f.ray_type; LANES],
            ray_depth: [f.ray_depth; LANES],
            seed: [f.seed; LANES],
            rand: f.rand.map(|x| [x; LANES]),
        }
    }
}

/// Any number of fragments as consecutive four-lane packets (see the module documentation).
/// The lanes past the last fragment repeat the first fragment of the last packet, so that
/// padding lanes compute something harmless; a batch entry does not count or report them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fragments {
    packets: Vec<FragmentX4>,
    len: usize,
}

impl Fragments {
    /// No fragments.
    pub fn new() -> Fragments {
        Fragments::default()
    }

    /// No fragments, with room for `n` without reallocating.
    pub fn with_capacity(n: usize) -> Fragments {
        Fragments {
            packets: Vec::with_capacity(n.div_ceil(LANES)),
            len: 0,
        }
    }

    /// The fragments of a slice, in order.
    pub fn from_slice(frags: &[Fragment]) -> Fragments {
        let mut out = Fragments::with_capacity(frags.len());
        for f in frags {
            out.push(f);
        }
        out
    }

    /// How many fragments.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Removes every fragment (keeps the memory).
    pub fn clear(&mut self) {
        self.packets.clear();
        self.len = 0;
    }

    /// Appends a fragment.
    pub fn push(&mut self, f: &Fragment) {
        let lane = self.len % LANES;
        if lane == 0 {
            self.packets.push(FragmentX4::splat(f));
        } else if let Some(last) = self.packets.last_mut() {
            last.set_lane(lane, f);
        }
        self.len += 1;
    }

    /// Fragment `i` (panics past the end, as slice indexing does).
    pub fn get(&self, i: usize) -> Fragment {
        assert!(i < self.len, "fragment {i} of {}", self.len);
        self.packets[i / LANES].lane(i % LANES)
    }

    /// Every fragment, in order.
    pub fn iter(&self) -> impl Iterator<Item = Fragment> + '_ {
        (0..self.len).map(|i| self.get(i))
    }

    /// The packets (`len().div_ceil(4)` of them).
    pub fn packets(&self) -> &[FragmentX4] {
        &self.packets
    }

    /// The packets, to change fragments in place (the count stays).
    pub fn packets_mut(&mut self) -> &mut [FragmentX4] {
        &mut self.packets
    }

    /// Replaces the contents with `n` fragments written straight into their packets:
    /// `fill(packet_index, packet)` fills packet `p` (fragments `4p .. 4p + 4`; the padding
    /// lanes of the last packet are the filler's to make harmless). For generators that
    /// compute four lanes at once (`shadenet shade`'s grid).
    pub fn fill(&mut self, n: usize, mut fill: impl FnMut(usize, &mut FragmentX4)) {
        self.packets.clear();
        self.packets
            .resize(n.div_ceil(LANES), FragmentX4::default());
        for (p, packet) in self.packets.iter_mut().enumerate() {
            fill(p, packet);
        }
        self.len = n;
    }
}

impl FromIterator<Fragment> for Fragments {
    fn from_iter<T: IntoIterator<Item = Fragment>>(iter: T) -> Fragments {
        let mut out = Fragments::new();
        for f in iter {
            out.push(&f);
        }
        out
    }
}

/// Floats a batch's output holds for `n` fragments of `width` floats each: whole packets,
/// `n.div_ceil(4) · width · 4`.
pub fn packed_len(width: usize, n: usize) -> usize {
    n.div_ceil(LANES) * width * LANES
}

/// Where output float `k` of fragment `i` is in a batch's output (`width` floats per
/// fragment): packet `i / 4`, then float `k` of its four lanes, then the lane.
pub fn packed_index(width: usize, i: usize, k: usize) -> usize {
    (i / LANES) * width * LANES + k * LANES + i % LANES
}

/// A batch's output (the packets' layout) as fragment after fragment, `width` floats each,
/// for the first `n` fragments.
pub fn unpacked(width: usize, n: usize, packed: &[f32]) -> Vec<f32> {
    (0..n * width)
        .map(|j| packed[packed_index(width, j / width, j % width)])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frag(i: u32) -> Fragment {
        Fragment {
            p: [i as f32, 1.0, 2.0],
            uv: [0.5, i as f32 * 0.25],
            seed: i,
            ray_depth: i as i32 % 3,
            rand: [0.1, 0.2, 0.3, i as f32],
            ..Fragment::default()
        }
    }

    #[test]
    fn fragments_round_trip_and_pad_with_the_packets_first() {
        for n in [0usize, 1, 3, 4, 5, 9] {
            let fs: Vec<Fragment> = (0..n as u32).map(frag).collect();
            let packed = Fragments::from_slice(&fs);
            assert_eq!(packed.len(), n);
            assert_eq!(packed.packets().len(), n.div_ceil(4));
            assert_eq!(packed.iter().collect::<Vec<_>>(), fs);
            if n % 4 != 0 {
                let last = packed.packets().last().unwrap();
                for lane in n % 4..4 {
                    assert_eq!(last.lane(lane), fs[n / 4 * 4], "n {n} lane {lane}");
                }
            }
            assert_eq!(fs.iter().copied().collect::<Fragments>(), packed);
        }
    }

    #[test]
    fn packed_index_walks_packets_then_floats_then_lanes() {
        let (w, n) = (3usize, 6usize);
        let mut seen = vec![false; packed_len(w, n)];
        assert_eq!(seen.len(), 24);
        for i in 0..n {
            for k in 0..w {
                let at = packed_index(w, i, k);
                assert!(!seen[at], "{i} {k}");
                seen[at] = true;
            }
        }
        assert_eq!(packed_index(w, 5, 2), 12 + 2 * 4 + 1);
        assert_eq!(seen.iter().filter(|s| **s).count(), 18);
        let packed: Vec<f32> = (0..24).map(|x| x as f32).collect();
        let flat = unpacked(w, n, &packed);
        assert_eq!(&flat[..4], &[0.0, 4.0, 8.0, 1.0]);
        assert_eq!(flat[5 * 3 + 2], 12.0 + 8.0 + 1.0);
    }
}

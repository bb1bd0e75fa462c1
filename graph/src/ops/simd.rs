//! Which SIMD copy the four-lane helpers ([`super::noise_x4`], [`super::math_x4`],
//! [`super::cell_hsv_x4`], [`super::osl_noise_x4`]) run, chosen
//! once per process (issue 23): owns [`Path`] — the copies there are, whether the CPU can run
//! each, and the `SHADENET_SIMD` switch that forces one. Owns no arithmetic.

use std::sync::OnceLock;

/// Which copy runs: `SHADENET_SIMD=lanes|base|sse4.1|avx2` forces one (the tests run each
/// the CPU has), else the widest the CPU has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Path {
    /// No four-lane code: the scalar function once per lane (what the batch entry did
    /// before the four-lane helpers; kept to measure against).
    Lanes,
    /// The baseline copy (x86-64: SSE2; `floor` is a call per lane).
    Base,
    /// SSE4.1 (`roundps` for `floor`, blends for selects).
    Sse41,
    /// AVX2 (four f64 lanes in one register).
    Avx2,
}

impl Path {
    /// Every path, narrowest first.
    pub const ALL: [Path; 4] = [Path::Lanes, Path::Base, Path::Sse41, Path::Avx2];

    /// Whether this CPU can run the copy.
    pub fn available(self) -> bool {
        match self {
            Path::Lanes | Path::Base => true,
            #[cfg(target_arch = "x86_64")]
            Path::Sse41 => std::arch::is_x86_feature_detected!("sse4.1"),
            #[cfg(target_arch = "x86_64")]
            Path::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The copy chosen for this process (see [`Path`]).
    pub fn chosen() -> Path {
        static CHOSEN: OnceLock<Path> = OnceLock::new();
        *CHOSEN.get_or_init(|| {
            let forced = match std::env::var("SHADENET_SIMD").ok().as_deref() {
                Some("lanes") => Some(Path::Lanes),
                Some("base") => Some(Path::Base),
                Some("sse4.1") => Some(Path::Sse41),
                Some("avx2") => Some(Path::Avx2),
                _ => None,
            };
            match forced {
                Some(p) if p.available() => p,
                _ => [Path::Avx2, Path::Sse41, Path::Base]
                    .into_iter()
                    .find(|p| p.available())
                    .unwrap_or(Path::Base),
            }
        })
    }
}

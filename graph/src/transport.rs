//! Light-transport options of the surface lowering (DESIGN §12): which estimators light a
//! closure. A lowering option — the surface lowering ([`crate::closure::shade`]) reads it as
//! a compile-time constant, so a strategy emits only the work it uses — that the renderer
//! must match when it weights the BSDF-sampled rays that reach a light.

use std::fmt;
use std::str::FromStr;

/// How closures gather the light of area lights and the environment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum LightStrategy {
    /// Next-event estimation and BSDF sampling combined by the power heuristic (default).
    #[default]
    Mis,
    /// Light sampling only: the light loop's weight is 1 and BSDF-sampled rays that reach an
    /// area light or the environment bring nothing of it (they still continue the path).
    Light,
    /// BSDF sampling only: area lights and the environment light a closure only through its
    /// BSDF-sampled rays (weight 1). Point, spot and distant lights, which no sampled
    /// direction can hit, stay in the light loop with weight 1.
    Bsdf,
}

impl LightStrategy {
    /// Every strategy, default first.
    pub const ALL: [LightStrategy; 3] = [
        LightStrategy::Mis,
        LightStrategy::Light,
        LightStrategy::Bsdf,
    ];

    /// The name scenes and the command line use: `mis`, `light` or `bsdf`.
    pub fn name(self) -> &'static str {
        match self {
            LightStrategy::Mis => "mis",
            LightStrategy::Light => "light",
            LightStrategy::Bsdf => "bsdf",
        }
    }

    /// The weight of what a BSDF-sampled ray of density `bsdf_pdf` finds on a light source
    /// the light loop samples with density `light_pdf` of that direction (0 or NaN: the loop
    /// does not sample it). A ray not drawn by BSDF sampling (`bsdf_pdf ≤ 0`) and a source
    /// the loop does not sample always take the full light.
    pub fn bsdf_ray_weight(self, bsdf_pdf: f32, light_pdf: f32) -> f32 {
        if bsdf_pdf <= 0.0 || light_pdf.is_nan() || light_pdf <= 0.0 {
            return 1.0;
        }
        match self {
            LightStrategy::Mis => {
                let (b, l) = (bsdf_pdf as f64, light_pdf as f64);
                let (b2, l2) = (b * b, l * l);
                if !b2.is_finite() {
                    return 1.0;
                }
                (b2 / (b2 + l2)) as f32
            }
            LightStrategy::Light => 0.0,
            LightStrategy::Bsdf => 1.0,
        }
    }
}

impl fmt::Display for LightStrategy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for LightStrategy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        LightStrategy::ALL
            .into_iter()
            .find(|x| x.name() == s)
            .ok_or_else(|| format!("unknown light strategy `{s}` (known: mis, light, bsdf)"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for s in LightStrategy::ALL {
            assert_eq!(s.name().parse::<LightStrategy>(), Ok(s));
        }
        let e = "MIS".parse::<LightStrategy>().unwrap_err();
        assert!(e.contains("`MIS`") && e.contains("mis, light, bsdf"), "{e}");
        assert_eq!(LightStrategy::default(), LightStrategy::Mis);
    }

    #[test]
    fn bsdf_ray_weights_complement_the_light_loop() {
        use LightStrategy::*;
        // Power heuristic: b² / (b² + l²).
        assert_eq!(Mis.bsdf_ray_weight(2.0, 1.0), 0.8);
        assert_eq!(Light.bsdf_ray_weight(2.0, 1.0), 0.0);
        assert_eq!(Bsdf.bsdf_ray_weight(2.0, 1.0), 1.0);
        // Not BSDF-sampled, or a source the loop does not sample: full light, every strategy.
        for s in LightStrategy::ALL {
            assert_eq!(s.bsdf_ray_weight(0.0, 1.0), 1.0);
            assert_eq!(s.bsdf_ray_weight(2.0, 0.0), 1.0);
            assert_eq!(s.bsdf_ray_weight(2.0, f32::NAN), 1.0);
        }
        assert_eq!(Mis.bsdf_ray_weight(f32::INFINITY, 1.0), 1.0);
    }
}

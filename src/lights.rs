//! Lights written as one-line strings: the syntax of `shadenet shade --light` and of the
//! Python package's `Material.shade(lights=[…])`.
//!
//! `point:X,Y,Z:INTENSITY[:R,G,B]`, `distant:DX,DY,DZ:INTENSITY[:R,G,B]`,
//! `spot:X,Y,Z:DX,DY,DZ:INTENSITY:CONE_DEG[:R,G,B]` and `ambient:INTENSITY[:R,G,B]`. This
//! module owns the syntax only; the rules a light's values obey are [`LightDesc::new`]'s,
//! shared with the light nodes and the scene file.

use shadenet_graph::nodes::{LightDesc, LightError, LightKind};

/// The light of `shadenet shade` when neither the network nor the command line has one.
pub const DEFAULT_LIGHT: &str = "point:1,1,2:20";

/// A light string that is not a light. The message says what is wrong, not which string:
/// the caller names the string (`--light SPEC: …`).
#[derive(Debug, thiserror::Error)]
pub enum LightSpecError {
    /// The string does not follow the syntax.
    #[error("{0}")]
    Syntax(String),
    /// The values break a rule every light obeys.
    #[error(transparent)]
    Invalid(#[from] LightError),
}

/// Parses one light string as a light named `light{index}`.
pub fn parse_light(spec: &str, index: usize) -> Result<LightDesc, LightSpecError> {
    let syntax = LightSpecError::Syntax;
    let parts: Vec<&str> = spec.split(':').collect();
    let vec3 = |s: &str| -> Result<[f64; 3], LightSpecError> {
        let v: Vec<f64> = s
            .split(',')
            .map(|x| x.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| syntax(format!("`{s}` is not X,Y,Z: {e}")))?;
        if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
            return Err(syntax(format!("`{s}` is not three finite numbers")));
        }
        Ok([v[0], v[1], v[2]])
    };
    let num = |s: &str| -> Result<f64, LightSpecError> {
        s.trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| syntax(format!("`{s}` is not a finite number")))
    };
    let power = |i: f64, color: Option<&&str>| -> Result<[f64; 3], LightSpecError> {
        let c = color.map(|c| vec3(c)).transpose()?.unwrap_or([1.0; 3]);
        Ok(c.map(|x| x * i))
    };
    let name = format!("light{index}");
    let (kind, pw) = match (parts[0], parts.len()) {
        ("point", 3 | 4) => (
            LightKind::Point {
                position: vec3(parts[1])?,
            },
            power(num(parts[2])?, parts.get(3))?,
        ),
        ("distant", 3 | 4) => (
            LightKind::Distant {
                direction: vec3(parts[1])?,
            },
            power(num(parts[2])?, parts.get(3))?,
        ),
        ("spot", 5 | 6) => (
            LightKind::Spot {
                position: vec3(parts[1])?,
                direction: vec3(parts[2])?,
                cone_angle: num(parts[4])?.to_radians(),
                penumbra_angle: 0.0,
                dropoff: 0.0,
            },
            power(num(parts[3])?, parts.get(5))?,
        ),
        ("ambient", 2 | 3) => (LightKind::Ambient, power(num(parts[1])?, parts.get(2))?),
        _ => {
            return Err(syntax(
                "expected point:X,Y,Z:I[:R,G,B], distant:DX,DY,DZ:I[:R,G,B], \
                 spot:X,Y,Z:DX,DY,DZ:I:CONE_DEG[:R,G,B] or ambient:I[:R,G,B]"
                    .into(),
            ));
        }
    };
    Ok(LightDesc::new(name, kind, pw)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each kind parses to its light (colour times intensity); bad strings say what is
    /// wrong.
    #[test]
    fn light_strings() {
        let l = parse_light("point:1,2,3:10:0.5,1,2", 4).unwrap();
        assert_eq!(l.name, "light4");
        assert_eq!(l.power, [5.0, 10.0, 20.0]);
        assert!(matches!(l.kind, LightKind::Point { position } if position == [1.0, 2.0, 3.0]));
        assert!(matches!(
            parse_light("ambient:2", 0).unwrap().kind,
            LightKind::Ambient
        ));
        let err = |s: &str| parse_light(s, 0).unwrap_err().to_string();
        assert!(err("laser:1").starts_with("expected point:"));
        assert!(err("point:1,2:1").contains("`1,2` is not three finite numbers"));
        assert!(err("point:0,0,2:inf").contains("`inf` is not a finite number"));
        assert!(err("distant:0,0,0:1").contains("direction"));
    }
}

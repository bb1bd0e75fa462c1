//! OSL's `texture(file, s, t, "name", value, …)` and `environment(file, R, "name", value,
//! …)` (a lat-long map looked up by direction): the optional token–value arguments after
//! the coordinates, and what each means here. It owns these rules:
//!
//! - `"swrap"`, `"twrap"`, `"wrap"` (both): a wrap mode by name — `"periodic"` (and
//!   `"default"`), `"clamp"`, `"mirror"`, `"black"`, and MaterialX's `"constant"`, which is
//!   `"black"` (its OSL returns the node's default itself where uv leaves the image, as
//!   our native image atoms do).
//! - `"interp"`: `"closest"` reads the nearest texel, `"linear"` bilinear, `"cubic"` and
//!   `"smartcubic"` the texture system's filtered lookup (its default).
//! - `"colorspace"`: the file's colour space by MaterialX's names (`""`: by the file's
//!   format, as without it).
//! - `"alpha"`: an output float that receives the lookup's alpha.
//! - `"subimage"`: only `""` (the first image; named layers are not built).
//! - `"width"`, `"swidth"`, `"twidth"` (`texture` only): factors of the filter footprint
//!   along s and t (0: the finest level, unfiltered); `"blur"`, `"sblur"`, `"tblur"`: the
//!   footprint widened along s and t by that much in texture coordinates (0.1 blurs over a
//!   tenth of the image); `"time"` is accepted and ignored (no texture varies in time, as in
//!   OpenImageIO). Ours widen `∂s/∂x` and `∂t/∂y`; OpenImageIO's exact ellipse arithmetic
//!   for blur is not reproduced.
//! - `"missingcolor"`, `"missingalpha"`: what a lookup of the empty file name `""` returns
//!   (black and 0 without them; MaterialX's OSL passes `""` for an unset file, as its
//!   nodes' defaults do). Any other file that cannot be read is an error when the material
//!   loads, so nothing else is ever missing at a lookup.
//!
//! Names and modes are strings, so compile-time values. Any other token is an error naming
//! it.

use super::builtins::st_uv;
use super::{Lower, Ty, Val};
use crate::ast::Expr;
use crate::source::Span;
use shadenet_graph::ir::{Builder, ColorSpace, Filter, Sampling, TextureFile, Value, Wrap};

/// The wrap mode an OSL wrap name stands for: the IR's names (`periodic`, `clamp`,
/// `mirror`, `black`), OSL's `default` and MaterialX's `constant`.
fn wrap(name: &str) -> Option<Wrap> {
    match name {
        "default" => Some(Wrap::Periodic),
        "constant" => Some(Wrap::Black),
        _ => Wrap::from_name(name),
    }
}

/// The filter an OSL `"interp"` name stands for.
fn filter(name: &str) -> Option<Filter> {
    Some(match name {
        "closest" => Filter::Closest,
        "linear" => Filter::Bilinear,
        "cubic" | "smartcubic" => Filter::Anisotropic,
        _ => return None,
    })
}

/// What the optional arguments of one call ask for.
struct Options<'a> {
    /// The builtin the options belong to (`texture`, `environment`), for errors.
    call: &'static str,
    sampling: Sampling,
    colorspace: ColorSpace,
    /// The expression receiving the alpha, if any, and its argument number (from 1).
    alpha: Option<(usize, &'a Expr)>,
    /// `"missingcolor"`'s value (a triple), if given, and whether it varies.
    missing_color: Option<(Value, bool)>,
    /// `"missingalpha"`'s value, if given, and whether it varies.
    missing_alpha: Option<(Value, bool)>,
    /// `"swidth"`, `"twidth"` (or `"width"`, both): factors of the footprint along s and t.
    width: [Option<(Value, Ty)>; 2],
    /// `"sblur"`, `"tblur"` (or `"blur"`, both): widening of the footprint along s and t, in
    /// texture coordinates.
    blur: [Option<(Value, Ty)>; 2],
}

impl<'a> Lower<'a> {
    /// `texture(file, s, t, "name", value, …)` with the arguments' values `vals` and
    /// expressions `args`: the color looked up, the alpha stored where asked.
    pub(crate) fn osl_texture(
        &mut self,
        b: &mut Builder,
        vals: &[(Val, Span)],
        args: &'a [Expr],
        span: Span,
    ) -> Val {
        let coords = match vals {
            [
                (Val::Str(file), _),
                (Val::V { v: s, ty: ts, .. }, _),
                (Val::V { v: t, ty: tt, .. }, _),
                ..,
            ] if *ts == Ty::Float && *tt == Ty::Float => Some((file.clone(), *s, *t)),
            _ => None,
        };
        let Some((file, s, t)) = coords else {
            self.error(
                "`texture` takes (string file, float s, float t) before its optional arguments",
                span,
                "wrong arguments",
            );
            return Self::poison(b, Ty::Color);
        };
        let Some(o) = self.texture_options("texture", &vals[3..], &args[3..], Sampling::default())
        else {
            return Self::poison(b, Ty::Color);
        };
        let uv = st_uv(b, s, t);
        self.texture_lookup(b, file, uv, o)
    }

    /// OSL's `environment(file, R, "name", value, …)`: the lat-long map's color in direction
    /// `R` (common space, any length), with `texture`'s options; periodic across the
    /// longitude and clamped at the poles unless the options say otherwise. The map's
    /// layout is that of the scene's image environment lights at rotation 0
    /// (`shadenet_graph::nodes::env_image::direction_to_uv`): `+y` up along the top row,
    /// the image's centre column looking along `−z`, the longitude `atan2(x, −z)` growing
    /// with the column. The footprint follows `R`'s derivatives through the arithmetic (the
    /// chain rule is continuous across the seam).
    pub(crate) fn osl_environment(
        &mut self,
        b: &mut Builder,
        vals: &[(Val, Span)],
        args: &'a [Expr],
        span: Span,
    ) -> Val {
        let found = match vals {
            [(Val::Str(file), _), (Val::V { v: r, ty, .. }, _), ..] if ty.is_triple() => {
                Some((file.clone(), *r))
            }
            _ => None,
        };
        let Some((file, r)) = found else {
            self.error(
                "`environment` takes (string file, vector R) before its optional arguments",
                span,
                "wrong arguments",
            );
            return Self::poison(b, Ty::Color);
        };
        let sampling = Sampling {
            wrap: [Wrap::Periodic, Wrap::Clamp],
            ..Sampling::default()
        };
        let Some(o) = self.texture_options("environment", &vals[2..], &args[2..], sampling) else {
            return Self::poison(b, Ty::Color);
        };
        let (s, t) = latlong(b, r);
        let uv = st_uv(b, s, t);
        self.texture_lookup(b, file, uv, o)
    }

    /// A lookup of `file` at `uv` with options `o` (the alpha stored where asked), or the
    /// missing values of the file `""`.
    fn texture_lookup(&mut self, b: &mut Builder, file: String, uv: Value, o: Options<'a>) -> Val {
        let (color, alpha) = if file.is_empty() {
            missing_texture(b, &o)
        } else {
            let file = TextureFile {
                path: file,
                colorspace: o.colorspace,
            };
            let index = b.texture_index(&file);
            let derivs = footprint(b, uv, &o);
            let c = b.texture_over(index, uv, derivs, o.sampling, false);
            let a = o
                .alpha
                .map(|_| b.texture_over(index, uv, derivs, o.sampling, true));
            ((c, true), a.map(|a| (a, true)))
        };
        if let (Some((n, target)), Some((v, varying))) = (o.alpha, alpha) {
            let a = Val::V {
                v,
                ty: Ty::Float,
                varying,
            };
            self.store_output_arg(b, target, a, (n, o.call));
        }
        Val::V {
            v: color.0,
            ty: Ty::Color,
            varying: color.1,
        }
    }

    /// The optional token–value pairs `vals` (expressions `args`); `None` after an error.
    fn texture_options(
        &mut self,
        call: &'static str,
        vals: &[(Val, Span)],
        args: &'a [Expr],
        sampling: Sampling,
    ) -> Option<Options<'a>> {
        let mut o = Options {
            call,
            sampling,
            colorspace: ColorSpace::Auto,
            alpha: None,
            missing_color: None,
            missing_alpha: None,
            width: [None; 2],
            blur: [None; 2],
        };
        let mut ok = true;
        for (k, pair) in vals.chunks(2).enumerate() {
            let [(Val::Str(token), at), (value, vat)] = pair else {
                self.error(
                    format!(
                        "`{call}`'s optional arguments are pairs of a token string and a value"
                    ),
                    pair[0].1,
                    "not a token–value pair",
                );
                return None;
            };
            let name = match value {
                Val::Str(s) => Some(s.as_str()),
                _ => None,
            };
            let bad = |me: &mut Self, what: &str| {
                me.error(
                    format!("`{call}` option \"{token}\": {what}"),
                    *vat,
                    "this value",
                );
            };
            match (token.as_str(), name) {
                ("swrap" | "twrap" | "wrap", Some(n)) => match wrap(n) {
                    Some(w) => match token.as_str() {
                        "swrap" => o.sampling.wrap[0] = w,
                        "twrap" => o.sampling.wrap[1] = w,
                        _ => o.sampling.wrap = [w; 2],
                    },
                    None => {
                        bad(
                            self,
                            "a wrap mode: periodic, clamp, mirror, black or constant",
                        );
                        ok = false;
                    }
                },
                ("interp", Some(n)) => match filter(n) {
                    Some(f) => o.sampling.filter = f,
                    None => {
                        bad(self, "closest, linear, cubic or smartcubic");
                        ok = false;
                    }
                },
                ("colorspace", Some("")) => o.colorspace = ColorSpace::Auto,
                ("colorspace", Some(n)) => match ColorSpace::parse(n) {
                    Some(c) => o.colorspace = c,
                    None => {
                        bad(self, "a colour space MaterialX names");
                        ok = false;
                    }
                },
                ("subimage", Some("")) => {}
                ("subimage", Some(_)) => {
                    bad(
                        self,
                        "named subimages (layers) are not built: the first image is read",
                    );
                    ok = false;
                }
                ("alpha", None) => o.alpha = args.get(2 * k + 1).map(|e| (2 * k + 5, e)),
                ("missingcolor", None) => match value {
                    Val::V { v, ty, varying } if ty.is_triple() => {
                        o.missing_color = Some((*v, *varying))
                    }
                    _ => {
                        bad(self, "a color");
                        ok = false;
                    }
                },
                ("missingalpha", None) => match value {
                    Val::V {
                        v,
                        ty: Ty::Float,
                        varying,
                    } => o.missing_alpha = Some((*v, *varying)),
                    _ => {
                        bad(self, "a float");
                        ok = false;
                    }
                },
                ("width" | "swidth" | "twidth" | "blur" | "sblur" | "tblur" | "time", _)
                    if call == "texture" =>
                {
                    let Val::V {
                        v,
                        ty: ty @ (Ty::Float | Ty::Int),
                        ..
                    } = value
                    else {
                        bad(self, "a float");
                        ok = false;
                        continue;
                    };
                    let slot = match token.as_str() {
                        // No texture varies in time (as in OpenImageIO, which ignores it).
                        "time" => continue,
                        t if t.ends_with("blur") => &mut o.blur,
                        _ => &mut o.width,
                    };
                    match token.as_bytes()[0] {
                        b's' => slot[0] = Some((*v, *ty)),
                        b't' => slot[1] = Some((*v, *ty)),
                        _ => *slot = [Some((*v, *ty)); 2],
                    }
                }
                ("swrap" | "twrap" | "wrap" | "interp" | "colorspace" | "subimage", None) => {
                    bad(self, "a string");
                    ok = false;
                }
                _ => {
                    self.error(
                        format!(
                            "`{call}` option \"{token}\" is not built (built: swrap, twrap, wrap, interp, colorspace, alpha, subimage \"\", missingcolor, missingalpha{})",
                            if call == "texture" {
                                ", width, swidth, twidth, blur, sblur, tblur, time"
                            } else {
                                ""
                            }
                        ),
                        *at,
                        "this option",
                    );
                    ok = false;
                }
            }
        }
        ok.then_some(o)
    }
}

/// The footprint of a lookup at `uv`: uv's derivatives for a filtered lookup (none for
/// `"closest"` and `"linear"`), each scaled along s and t by the `"width"` factors, then
/// `∂s/∂x` and `∂t/∂y` lengthened by the `"blur"` amounts (away from zero) — a footprint
/// at least `blur` wide along each axis, zero derivatives included.
fn footprint(b: &mut Builder, uv: Value, o: &Options) -> Option<[Value; 2]> {
    use shadenet_graph::Type;
    use shadenet_graph::ir::{BinOp, UnOp};
    if matches!(o.sampling.filter, Filter::Closest | Filter::Bilinear) {
        return None;
    }
    let own = b.derivs(uv);
    if o.width == [None; 2] && o.blur == [None; 2] {
        return own;
    }
    let [dx, dy] = own.unwrap_or_else(|| [b.zero(Type::Vec2), b.zero(Type::Vec2)]);
    let float = |b: &mut Builder, x: Option<(Value, Ty)>, default: f64| match x {
        Some((v, Ty::Int)) => b.convert(Type::Float, v),
        Some((v, _)) => v,
        None => b.float(default),
    };
    let (dx, dy) = if o.width == [None; 2] {
        (dx, dy)
    } else {
        let (sw, tw) = (float(b, o.width[0], 1.0), float(b, o.width[1], 1.0));
        let w = b.construct(Type::Vec2, &[sw, tw]);
        (b.mul(dx, w), b.mul(dy, w))
    };
    // Component `k` of `d` lengthened by the blur along that axis, where one is given.
    let mut widen = |d: Value, k: usize| {
        if o.blur[k].is_none() {
            return d;
        }
        let amount = float(b, o.blur[k], 0.0);
        let mut c = [b.extract(d, 0), b.extract(d, 1)];
        let zero = b.float(0.0);
        let neg = b.binary(BinOp::Lt, c[k], zero);
        let minus = b.unary(UnOp::Neg, amount);
        let step = b.select(neg, minus, amount);
        c[k] = b.add(c[k], step);
        b.construct(Type::Vec2, &c)
    };
    Some([widen(dx, 0), widen(dy, 1)])
}

/// The lat-long map coordinates `(s, t)` of direction `r` (OSL's `t` down from the top
/// row): `s = 0.5 + atan2(x, −z)/(2π)`, `t = atan2(√(x² + z²), y)/π`.
fn latlong(b: &mut Builder, r: Value) -> (Value, Value) {
    use shadenet_graph::ir::{BinOp, UnOp};
    let r = b.retype(shadenet_graph::Type::Vec3, r);
    let (x, y, z) = (b.extract(r, 0), b.extract(r, 1), b.extract(r, 2));
    let xz = b.construct(shadenet_graph::Type::Vec2, &[x, z]);
    let sin_t = b.unary(UnOp::Length, xz);
    let theta = b.binary(BinOp::Atan2, sin_t, y);
    let nz = b.unary(UnOp::Neg, z);
    let phi = b.binary(BinOp::Atan2, x, nz);
    let k = b.float(0.5 / std::f64::consts::PI);
    let half = b.float(0.5);
    let s = b.mul(phi, k);
    let s = b.add(half, s);
    let inv_pi = b.float(1.0 / std::f64::consts::PI);
    (s, b.mul(theta, inv_pi))
}

/// A `texture` call's color and, where asked, its alpha, each with whether it varies.
type Looked = ((Value, bool), Option<(Value, bool)>);

/// A lookup of the file `""`: the missing color (black unless given) and, where the call
/// asks for it, the missing alpha (0 unless given); no texture is opened.
fn missing_texture(b: &mut Builder, o: &Options<'_>) -> Looked {
    let color = match o.missing_color {
        Some((c, vy)) => (b.retype(shadenet_graph::Type::Color, c), vy),
        None => (b.color([0.0; 3]), false),
    };
    let alpha = o
        .alpha
        .map(|_| o.missing_alpha.unwrap_or_else(|| (b.float(0.0), false)));
    (color, alpha)
}

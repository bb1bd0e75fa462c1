//! What a program says about its textures: which file each texture-table entry names and in
//! which color space its values are stored ([`TextureFile`]), and how a lookup filters and
//! wraps ([`Sampling`]).
//!
//! These are attributes of the IR, read by the runtime's texture system (which owns the files,
//! the decoding, the mipmaps and the filters) and by the back ends. This module holds no image
//! code and must not: the graph crate never opens a texture.

named_enum! {
    /// How a texture file's stored values map to the working space, linear Rec.709 (the
    /// MaterialX color-space names; `auto` and `raw` are ours).
    ColorSpace {
        /// By the file's format: 8- and 16-bit integer images are `srgb_texture`, floating
        /// point images (EXR, Radiance HDR) `lin_rec709`.
        Auto = "auto",
        /// No conversion at all: data such as normals, roughness or masks.
        Raw = "raw",
        /// Linear Rec.709 primaries: the working space, no conversion.
        LinRec709 = "lin_rec709",
        /// The sRGB transfer function over Rec.709 primaries.
        SrgbTexture = "srgb_texture",
        /// A pure 2.2 gamma over Rec.709 primaries.
        G22Rec709 = "g22_rec709",
        /// A pure 1.8 gamma over Rec.709 primaries.
        G18Rec709 = "g18_rec709",
        /// The Rec.709 display transfer over Rec.709 primaries: a 2.4 power (BT.1886 with a
        /// zero black level, as MaterialX's cmlib).
        Rec709Display = "rec709_display",
        /// Linear AP1 primaries with the ACES white point (ACEScg).
        AcesCg = "acescg",
        /// A 2.2 gamma over AP1 primaries.
        G22Ap1 = "g22_ap1",
        /// Linear Adobe RGB (1998) primaries.
        LinAdobeRgb = "lin_adobergb",
        /// Adobe RGB (1998): its 563/256 gamma over its primaries.
        AdobeRgb = "adobergb",
        /// Linear Display P3 primaries.
        LinDisplayP3 = "lin_displayp3",
        /// The sRGB transfer function over Display P3 primaries.
        SrgbDisplayP3 = "srgb_displayp3",
    }
}

impl ColorSpace {
    /// Parses a color-space name, accepting the aliases other tools write (`lin_ap1` for
    /// `acescg`, `srgb` for `srgb_texture`, `linear` for `lin_rec709`, and `none` for `raw`).
    pub fn parse(name: &str) -> Option<ColorSpace> {
        match name {
            "lin_ap1" => Some(ColorSpace::AcesCg),
            "srgb" | "sRGB" => Some(ColorSpace::SrgbTexture),
            "linear" => Some(ColorSpace::LinRec709),
            "none" | "" => Some(ColorSpace::Raw),
            other => ColorSpace::from_name(other),
        }
    }
}

named_enum! {
    /// How a lookup filters the texels under its footprint.
    Filter {
        /// The nearest texel of the finest level, no filtering (MaterialX `closest`).
        Closest = "closest",
        /// Bilinear interpolation in the finest level, whatever the footprint.
        Bilinear = "bilinear",
        /// Bilinear in the two mip levels around the footprint's width, blended (isotropic:
        /// blurs along the footprint's short axis at grazing angles).
        Trilinear = "trilinear",
        /// Trilinear probes along the footprint's long axis at the level of its short axis:
        /// what a renderer does by default.
        Anisotropic = "anisotropic",
    }
}

named_enum! {
    /// What a lookup reads outside [0, 1] along one texture axis.
    Wrap {
        /// The image repeats (MaterialX `periodic`).
        Periodic = "periodic",
        /// The edge texels extend (MaterialX `clamp`).
        Clamp = "clamp",
        /// The image repeats mirrored every other period (MaterialX `mirror`).
        Mirror = "mirror",
        /// Transparent black outside (MaterialX `constant` is this plus the node's default,
        /// chosen by the lowering where uv leaves the image).
        Black = "black",
    }
}

/// One entry of a program's texture table: a file and the color space of its values.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct TextureFile {
    /// The path as the network gave it (made absolute by the loader when the network came
    /// from a file). `<UDIM>` in the name stands for the tile number (1001, 1002, …).
    pub path: String,
    /// How its stored values map to linear Rec.709.
    pub colorspace: ColorSpace,
}

impl TextureFile {
    /// A file whose color space follows its format ([`ColorSpace::Auto`]).
    pub fn auto(path: impl Into<String>) -> TextureFile {
        TextureFile {
            path: path.into(),
            colorspace: ColorSpace::Auto,
        }
    }
}

/// How one lookup reads its texture: the filter and the wrap mode of each axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Sampling {
    /// The filter over the footprint.
    pub filter: Filter,
    /// Wrap modes of u and v.
    pub wrap: [Wrap; 2],
}

impl Default for Sampling {
    /// Anisotropic filtering, periodic in both axes.
    fn default() -> Self {
        Sampling {
            filter: Filter::Anisotropic,
            wrap: [Wrap::Periodic; 2],
        }
    }
}

impl Sampling {
    /// The sampling in six bits (filter, then u and v wrap modes, two bits each): what the
    /// back ends pass beside a texture index.
    pub fn bits(self) -> u32 {
        let f = Filter::ALL
            .iter()
            .position(|x| *x == self.filter)
            .unwrap_or(0) as u32;
        let w = |m: Wrap| Wrap::ALL.iter().position(|x| *x == m).unwrap_or(0) as u32;
        f | w(self.wrap[0]) << 2 | w(self.wrap[1]) << 4
    }

    /// The sampling of [`Sampling::bits`]; bits above the sixth are ignored.
    pub fn from_bits(bits: u32) -> Sampling {
        let f = Filter::ALL[(bits & 3) as usize];
        let w = |k: u32| Wrap::ALL[((bits >> k) & 3) as usize];
        Sampling {
            filter: f,
            wrap: [w(2), w(4)],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampling_bits_round_trip() {
        let mut seen = std::collections::HashSet::new();
        for &filter in Filter::ALL {
            for &u in Wrap::ALL {
                for &v in Wrap::ALL {
                    let s = Sampling {
                        filter,
                        wrap: [u, v],
                    };
                    assert!(s.bits() < 64);
                    assert!(seen.insert(s.bits()), "{s:?} shares its bits");
                    assert_eq!(Sampling::from_bits(s.bits()), s);
                }
            }
        }
    }

    #[test]
    fn colorspace_names_and_aliases_parse() {
        for &c in ColorSpace::ALL {
            assert_eq!(ColorSpace::parse(c.name()), Some(c));
        }
        assert_eq!(ColorSpace::parse("lin_ap1"), Some(ColorSpace::AcesCg));
        assert_eq!(ColorSpace::parse("srgb"), Some(ColorSpace::SrgbTexture));
        assert_eq!(ColorSpace::parse("none"), Some(ColorSpace::Raw));
        assert_eq!(ColorSpace::parse("lin_rec2020"), None);
    }
}

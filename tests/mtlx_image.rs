//! MaterialX `image` nodes: the file's `colorspace` (own or inherited), `filtertype` and
//! the address modes reach the IR's texture table and lookups, `constant` reads the
//! default outside [0, 1], and bad values are errors naming the input. Needs the MaterialX
//! libraries (fails without them when `CI` is set, skips otherwise).

mod common;
use common::*;
use shadenet::graph::error_chain;
use shadenet::graph::ir::{ColorSpace, Filter, Op, Sampling, TextureFile, Wrap};
use shadenet::graph::mtlx::{self, Library, Selection};

fn lib() -> Option<&'static Library> {
    mtlx_library()
}

/// A 2×2 PNG (top row red, green; bottom row blue, white) in a fresh folder; its path.
fn png(name: &str) -> String {
    let d = std::env::temp_dir().join(format!("shadenet-mximg-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join("t.png");
    let px: Vec<u8> = vec![255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255];
    image::save_buffer(&p, &px, 2, 2, image::ExtendedColorType::Rgb8).unwrap();
    p.to_string_lossy().into_owned()
}

fn doc(root_colorspace: &str, image: &str) -> String {
    format!(
        "<?xml version=\"1.0\"?>\n<materialx version=\"1.39\"{root_colorspace}>\n{image}\n\
         <output name=\"out\" type=\"color3\" nodename=\"img\"/>\n</materialx>\n"
    )
}

fn compile(src: &str) -> Result<shadenet::Compiled, String> {
    let lib = lib().expect("checked by the caller");
    mtlx::compile("t.mtlx", src, lib, &Selection::default()).map_err(|e| error_chain(&e))
}

/// The samplings of the program's texture lookups.
fn samplings(c: &shadenet::Compiled) -> Vec<Sampling> {
    c.program
        .exprs
        .iter()
        .filter_map(|e| match &e.op {
            Op::Texture { sampling, .. } => Some(*sampling),
            _ => None,
        })
        .collect()
}

#[test]
fn image_attributes_reach_the_texture_table_and_the_lookups() {
    if lib().is_none() {
        return;
    }
    let file = png("attrs");
    let img = format!(
        r#"<image name="img" type="color3">
             <input name="file" type="filename" value="{file}" colorspace="srgb_texture"/>
             <input name="default" type="color3" value="0.1, 0.2, 0.3"/>
             <input name="uaddressmode" type="string" value="constant"/>
             <input name="vaddressmode" type="string" value="mirror"/>
             <input name="filtertype" type="string" value="closest"/>
           </image>"#
    );
    let c = compile(&doc(" colorspace=\"lin_rec709\"", &img)).unwrap();
    assert_eq!(
        c.program.textures,
        vec![TextureFile {
            path: file.clone(),
            colorspace: ColorSpace::SrgbTexture
        }]
    );
    assert_eq!(
        samplings(&c),
        vec![Sampling {
            filter: Filter::Closest,
            wrap: [Wrap::Black, Wrap::Mirror]
        }]
    );
    let at = |uv: [f32; 2]| {
        let mut f = plane_fragment();
        f.uv = uv;
        run_program(&c.program, &f, &[], u32::MAX).get("out")
    };
    // Inside: the top-left texel, red after the sRGB decode (1 → 1).
    assert_close(&at([0.25, 0.75]), &[1.0, 0.0, 0.0], 0.0, "inside");
    // `constant` along u: the default outside [0, 1].
    assert_close(&at([1.5, 0.75]), &[0.1, 0.2, 0.3], 1e-7, "u outside");
    assert_close(&at([-0.01, 0.75]), &[0.1, 0.2, 0.3], 1e-7, "u below");
    // `mirror` along v: 1.25 reads the row at 0.75.
    assert_close(&at([0.25, 1.25]), &[1.0, 0.0, 0.0], 0.0, "v mirrored");
}

#[test]
fn colorspace_is_inherited_and_defaults_to_the_working_space() {
    if lib().is_none() {
        return;
    }
    let file = png("inherit");
    let img = format!(
        r#"<image name="img" type="color3"><input name="file" type="filename" value="{file}"/></image>"#
    );
    for (root, want) in [
        (" colorspace=\"acescg\"", ColorSpace::AcesCg),
        (" colorspace=\"srgb_texture\"", ColorSpace::SrgbTexture),
        ("", ColorSpace::LinRec709),
    ] {
        let c = compile(&doc(root, &img)).unwrap();
        assert_eq!(c.program.textures[0].colorspace, want, "root{root}");
        // The default filter is anisotropic with derivatives of uv; periodic wrap.
        assert_eq!(samplings(&c), vec![Sampling::default()]);
    }
}

#[test]
fn bad_image_attributes_name_the_input() {
    if lib().is_none() {
        return;
    }
    let file = png("bad");
    for (attr, needle) in [
        (
            format!(
                r#"<input name="file" type="filename" value="{file}" colorspace="lin_rec2021"/>"#
            ),
            "lin_rec2021",
        ),
        (
            format!(
                r#"<input name="file" type="filename" value="{file}"/>
                   <input name="uaddressmode" type="string" value="wrap"/>"#
            ),
            "uaddressmode",
        ),
        (
            format!(
                r#"<input name="file" type="filename" value="{file}"/>
                   <input name="filtertype" type="string" value="gaussian"/>"#
            ),
            "filtertype",
        ),
    ] {
        let img = format!(r#"<image name="img" type="color3">{attr}</image>"#);
        let e = compile(&doc("", &img)).unwrap_err();
        assert!(e.contains(needle) && e.contains("img"), "{e}");
    }
}

/// `tiledimage` (a graph over `image`) forwards its string inputs through `interfacename`:
/// the file and the filter reach the lookup, which reads the tiled uv.
#[test]
fn tiledimage_forwards_its_file_and_filter_to_the_image() {
    if lib().is_none() {
        return;
    }
    let file = png("tiled");
    let img = format!(
        r#"<tiledimage name="img" type="color3">
             <input name="file" type="filename" value="{file}"/>
             <input name="filtertype" type="string" value="closest"/>
             <input name="uvtiling" type="vector2" value="2, 2"/>
           </tiledimage>"#
    );
    let c = compile(&doc("", &img)).unwrap();
    assert_eq!(c.program.textures.len(), 1);
    assert_eq!(c.program.textures[0].path, file);
    assert_eq!(samplings(&c).len(), 1);
    assert_eq!(samplings(&c)[0].filter, Filter::Closest);
    let at = |uv: [f32; 2]| {
        let mut f = plane_fragment();
        f.uv = uv;
        run_program(&c.program, &f, &[], u32::MAX).get("out")
    };
    // Tiled twice: uv (0.125, 0.375) reads the texture at (0.25, 0.75), the red texel;
    // (0.375, 0.375) reads (0.75, 0.75), green.
    assert_close(&at([0.125, 0.375]), &[1.0, 0.0, 0.0], 0.0, "first tile");
    assert_close(
        &at([0.375, 0.375]),
        &[0.0, 1.0, 0.0],
        0.0,
        "first tile, right",
    );
    assert_close(&at([0.625, 0.875]), &[1.0, 0.0, 0.0], 0.0, "second tile");
    // An unknown filter named through the interface is still an error naming the input.
    let bad = img.replace("closest", "bicubic");
    let e = compile(&doc("", &bad)).unwrap_err();
    assert!(e.contains("filtertype") && e.contains("bicubic"), "{e}");
}

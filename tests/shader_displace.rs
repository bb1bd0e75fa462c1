//! `displacement` shaders (issues 21 and 22): alone they compile to the displaced `P` and
//! `N`; with a surface (`lower::compile_displaced`, `shader::load_displaced`, a scene
//! material's `displacement` key) the surface shades with the displaced normal (bump
//! mapping). Checked against the same computation written inline, OSL (the renderer's
//! normal of the displaced surface) and RSL (the shader's own `N`), on fragments with ray
//! differentials; the JIT against the interpreter; a render; and the errors.

mod common;
use common::*;
use shadenet::graph::ir::Program;
use shadenet::lang::{Dialect, Options, SourceMap, lower, parse_str};
use shadenet::runtime::Fragment;

const BUMP: &str = "displacement bumpy(float amp = 0.05, float freq = 8) {
    P += amp * noise(\"perlin\", P * freq) * normalize(N);
}";

/// Parses `src` (`name` says the dialect) into `sm`.
fn parsed(sm: &mut SourceMap, name: &str, src: &str) -> shadenet::lang::Parsed {
    let dialect = if name.ends_with(".osl") {
        Dialect::Osl
    } else {
        Dialect::Rsl
    };
    parse_str(sm, name, src, &Options::new(dialect)).unwrap_or_else(|e| panic!("{}", e.render(sm)))
}

fn displaced(surface: (&str, &str), displacement: (&str, &str)) -> Result<Program, String> {
    let mut sm = SourceMap::new();
    let s = parsed(&mut sm, surface.0, surface.1);
    let d = parsed(&mut sm, displacement.0, displacement.1);
    lower::compile_displaced(&s, &d).map_err(|e| e.render(&sm))
}

/// Fragments on a tilted, curved patch with ray differentials.
fn fragments() -> Vec<Fragment> {
    (0..6)
        .map(|k| {
            let t = k as f32 * 0.37;
            let n = [0.3 * t.sin(), 0.2, 1.0];
            let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            Fragment {
                p: [0.2 + t, -0.4 * t, 0.1 * t * t],
                n: n.map(|x| x / l),
                ng: [0.0, 0.0, 1.0],
                i: [0.0, 0.0, -1.0],
                uv: [0.1 * t, 0.5],
                dpdu: [1.0, 0.0, 0.0],
                dpdv: [0.0, 1.0, 0.0],
                dpdx: [0.01, 0.001, 0.0],
                dpdy: [0.0005, 0.012, 0.002],
                ..Fragment::default()
            }
        })
        .collect()
}

/// An OSL bump: the surface sees `normalize(calculatenormal(P'))` on `N`'s side.
#[test]
fn an_osl_bump_shades_with_the_displaced_normal() {
    let surface = "shader s(output color c = 0) { c = color(N); }";
    let p = displaced(("s.osl", surface), ("bumpy.osl", BUMP)).unwrap();
    let names: Vec<&str> = p.params.iter().map(|q| q.name.as_str()).collect();
    assert_eq!(names, ["displacement.amp", "displacement.freq"]);
    let inline = compile_shader(
        "shader s(output color c = 0) {
            point Pd = P + 0.05 * noise(\"perlin\", P * 8) * normalize(N);
            normal n = normalize(calculatenormal(Pd));
            if (dot(n, N) < 0) n = -n;
            c = color(n);
        }",
        Dialect::Osl,
    )
    .unwrap();
    let mut moved = 0;
    for f in fragments() {
        let a = run_program(&p, &f, &[], u32::MAX);
        let b = run_program(&inline, &f, &[], u32::MAX);
        assert_close(&a.get("c"), &b.get("c"), 1e-6, "f64");
        assert_close(&a.get32("c"), &b.get32("c"), 1e-5, "f32");
        let n0: Vec<f64> = f.n.iter().map(|x| *x as f64).collect();
        if a.get("c")
            .iter()
            .zip(&n0)
            .any(|(x, y)| (x - y).abs() > 1e-3)
        {
            moved += 1;
        }
    }
    assert!(moved >= 4, "the bump changes the normal ({moved} of 6)");
    // Alone, the shader's outputs are the displaced P and N.
    let alone = compile_shader(BUMP, Dialect::Osl).unwrap();
    let outs: Vec<&str> = alone.outputs.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(outs, ["P", "N"]);
}

/// RSL: the shader's own `N` (here set unnormalized, as RenderMan's shaders do), the JIT's
/// scalar and batch entries bit for bit with the interpreter on a grid.
#[test]
fn an_rsl_displacement_sets_its_own_normal() {
    let disp = "displacement lift(float k = 0.1) { P += k * normalize(N); N = normalize(N + vector(k, 0, 0)); }";
    let surface = "surface s() { Ci = color(xcomp(N), ycomp(N), zcomp(N)); }";
    let p = displaced(("s.sl", surface), ("lift.sl", disp)).unwrap();
    for f in fragments() {
        let o = run_program(&p, &f, &[], u32::MAX);
        let m = [f.n[0] as f64 + 0.1, f.n[1] as f64, f.n[2] as f64];
        let l = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        assert_close(&o.get("Ci"), &m.map(|x| x / l), 1e-6, "Ci");
    }
    assert_jit_is_interp(&p, 9, 7);
}

#[test]
fn displacement_errors_name_the_shader() {
    let surface = "shader s(output color c = 0) { c = color(N); }";
    let err = displaced(("s.osl", surface), ("t.osl", surface)).unwrap_err();
    assert!(
        err.contains(
            "this is a generic (OSL `shader`) shader: a displacement shader is needed here"
        ),
        "{err}"
    );
    let err = displaced(("d.osl", BUMP), ("b.osl", BUMP)).unwrap_err();
    assert!(err.contains("a surface shader is needed here"), "{err}");
}

/// A scene material's `displacement` key: the bumped floor renders differently from the
/// flat one; on a network material it is an error naming the material.
#[test]
fn a_scene_material_takes_a_displacement_shader() {
    let dir = tmp("displace", "scene");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("bumpy.osl"), BUMP.replace("0.05", "0.2")).unwrap();
    std::fs::write(
        dir.join("matte.osl"),
        "surface matte() { Ci = diffuse(N); }",
    )
    .unwrap();
    let scene = |disp: &str| {
        format!(
            "[camera]\nposition = [0.0, 3.0, 3.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 40\nresolution = [24, 16]\n\
             [render]\nspp = 1\n\
             [materials.floor]\nnetwork = \"matte.osl\"\n{disp}\n\
             [meshes.ground]\ntype = \"quad\"\n\
             [[instances]]\nname = \"floor\"\nmesh = \"ground\"\nmaterial = \"floor\"\nrotate = [-90, 0, 0]\nscale = 3\n\
             [[lights]]\ntype = \"point\"\nposition = [1.0, 2.0, 1.0]\nintensity = 10\n"
        )
    };
    let render = |text: &str| {
        let path = dir.join("scene.toml");
        std::fs::write(&path, text).unwrap();
        let opts = shadenet::render::RenderOptions::default();
        let r = shadenet::render::setup(Some(&path), &opts)?;
        Ok::<_, shadenet::render::SetupError>(beauty_bits(&r.render(&|_, _| {}).0))
    };
    let flat = render(&scene("")).unwrap();
    let bumped = render(&scene("displacement = \"bumpy.osl\"")).unwrap();
    let differ = flat.iter().zip(&bumped).filter(|(a, b)| a != b).count();
    assert!(
        differ > flat.len() / 4,
        "{differ} of {} values differ",
        flat.len()
    );
    // The displacement's parameters are set as "displacement.NAME".
    let stronger = render(&scene(
        "displacement = \"bumpy.osl\"\nset = { \"displacement.amp\" = 0.6 }",
    ))
    .unwrap();
    assert_ne!(stronger, bumped);
    let err = render(&scene(
        "displacement = \"bumpy.osl\"\nset = { \"displacement.amplitude\" = 0.6 }",
    ))
    .unwrap_err()
    .to_string();
    assert!(err.contains("displacement.amplitude"), "{err}");
    let err = render(&scene("displacement = \"bumpy.osl\"").replace(
        "network = \"matte.osl\"",
        "inline = { nodes = [{ id = \"l\", type = \"lambert\" }], outputs = { color = \"l.outColor\" } }",
    ))
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("material `floor`")
            && err.contains("`displacement` applies to a shader-source material"),
        "{err}"
    );
}

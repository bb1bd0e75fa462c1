//! Helpers shared by the integration tests: run one node or one network through the
//! interpreter in f32 and f64.
#![allow(dead_code)]

pub mod stats;

use shadenet_graph::ir::Program;
use shadenet_graph::lower::{Literal, lower_single};
use shadenet_graph::nodes::{LightDesc, NodeLibrary};
use shadenet_graph::types::{ConstValue, Type};
use shadenet_runtime::{Fragment, Interpreter, ShadeCtx, ShadeEnv};

/// One output entry: name, component (None for untagged), f32 values widened, f64 values.
pub type Entry = (String, Option<String>, Vec<f64>, Vec<f64>);

/// The outputs of one shading call, in f32 and in f64.
#[derive(Debug, Clone)]
pub struct Outputs {
    /// (output name, component name or None, f32 values widened, f64 values)
    pub entries: Vec<Entry>,
    /// Non-finite values caught by the guard in the f32 run.
    pub nonfinite32: u32,
    /// Loop executions the iteration limit stopped, in the f32 run and in the f64 run.
    pub loop_limits: [u32; 2],
}

impl Outputs {
    /// Total of output `name` in the f64 run (sum of its component parts).
    pub fn get(&self, name: &str) -> Vec<f64> {
        self.total(name, |e| &e.3)
    }

    /// Total of output `name` in the f32 run.
    pub fn get32(&self, name: &str) -> Vec<f64> {
        self.total(name, |e| &e.2)
    }

    /// The f64 value of one component part of output `name`.
    pub fn part(&self, name: &str, component: &str) -> Option<Vec<f64>> {
        self.entries
            .iter()
            .find(|e| e.0 == name && e.1.as_deref() == Some(component))
            .map(|e| e.3.clone())
    }

    fn total(&self, name: &str, pick: impl Fn(&Entry) -> &Vec<f64>) -> Vec<f64> {
        let mut sum: Option<Vec<f64>> = None;
        for e in self.entries.iter().filter(|e| e.0 == name) {
            let v = pick(e);
            sum = Some(match sum {
                None => v.clone(),
                Some(s) => s.iter().zip(v).map(|(a, b)| a + b).collect(),
            });
        }
        sum.unwrap_or_else(|| panic!("no output {name}; have {:?}", self.entries))
    }
}

/// A fragment at the origin of the z = 0 plane, facing +z, seen from (0, 0, 1).
pub fn plane_fragment() -> Fragment {
    Fragment {
        p: [0.0, 0.0, 0.0],
        n: [0.0, 0.0, 1.0],
        ng: [0.0, 0.0, 1.0],
        i: [0.0, 0.0, -1.0],
        uv: [0.5, 0.5],
        dpdu: [1.0, 0.0, 0.0],
        dpdv: [0.0, 1.0, 0.0],
        ..Fragment::default()
    }
}

/// Runs `program` on one fragment in f32 and f64.
pub fn run_program(program: &Program, frag: &Fragment, lights: &[LightDesc], mask: u32) -> Outputs {
    let env = ShadeEnv::with_lights(lights);
    let mut ctx = ShadeCtx::new(*frag, &env);
    ctx.mask = mask;
    let i32_ = Interpreter::<f32>::new(program).expect("textures load");
    let i64_ = Interpreter::<f64>::new(program).expect("textures load");
    let o32 = i32_.shade(&ctx);
    let o64 = i64_.shade(&ctx);
    let mut entries = Vec::new();
    for slot in i32_.slots() {
        let w = slot.ty.width().max(1);
        let comp = slot
            .component
            .map(|k| program.components[k as usize].clone());
        let v32 = o32.values[slot.offset..slot.offset + w]
            .iter()
            .map(|x| *x as f64)
            .collect();
        let v64 = o64.values[slot.offset..slot.offset + w].to_vec();
        entries.push((slot.name.clone(), comp, v32, v64));
    }
    Outputs {
        entries,
        nonfinite32: o32.nonfinite,
        loop_limits: [o32.loop_limits, o64.loop_limits],
    }
}

/// Lowers a single node with literal inputs and runs it on `frag` with `lights`, every
/// component active.
pub fn eval_node(
    node: &str,
    generic: Type,
    inputs: &[(&str, Literal)],
    frag: &Fragment,
    lights: &[LightDesc],
) -> Outputs {
    let lib = NodeLibrary::standard();
    let program = lower_single(&lib, node, generic, inputs).unwrap_or_else(|e| panic!("{e}"));
    run_program(&program, frag, lights, u32::MAX)
}

/// Shorthand: a float literal.
pub fn f(x: f64) -> Literal {
    Literal::Const(ConstValue::Float(x))
}

/// Shorthand: a color literal.
pub fn c(r: f64, g: f64, b: f64) -> Literal {
    Literal::Const(ConstValue::Color([r, g, b]))
}

/// Shorthand: a vec3 literal.
pub fn v(x: f64, y: f64, z: f64) -> Literal {
    Literal::Const(ConstValue::Vec3([x, y, z]))
}

/// Shorthand: a string literal.
pub fn s(x: &str) -> Literal {
    Literal::Const(ConstValue::String(x.to_string()))
}

/// Asserts two float slices agree within `tol` (absolute), with a message.
pub fn assert_close(got: &[f64], want: &[f64], tol: f64, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= tol || (g.is_nan() && w.is_nan()),
            "{what}[{i}]: got {g}, want {w} (tol {tol}); all: {got:?} vs {want:?}"
        );
    }
}

/// Runs the `shadenet` binary in the repository root: (exit code, stdout, stderr).
pub fn shadenet(args: &[&str]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_shadenet"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run shadenet");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A path in this test process's own temporary folder `shadenet-<group>-<pid>`.
pub fn tmp(group: &str, name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("shadenet-{group}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Runs the `shadenet` binary with extra environment variables: (exit code, stdout, stderr).
pub fn shadenet_env(args: &[&str], env: &[(&str, &str)]) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_shadenet"))
        .args(args)
        .envs(env.iter().copied())
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run shadenet");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Whether the GPU back end has a device: `shadenet_gpu::testing::device_or_skip` (without
/// one it prints `SKIPPED: <test>: <why>` and the test returns; with
/// `SHADENET_REQUIRE_GPU=1` a missing device fails the test instead).
pub fn gpu_or_skip(test: &str) -> bool {
    shadenet_gpu::testing::device_or_skip(test).is_some()
}

/// The accuracy class the GPU tests check on the shared device (bit-exact on a software
/// rasterizer, the hardware contract on a hardware GPU or under
/// `SHADENET_GPU_ACCURACY=hardware`); `None` without a device.
pub fn gpu_accuracy() -> Option<shadenet_gpu::Accuracy> {
    shadenet_gpu::GpuContext::shared()
        .ok()
        .map(|c| shadenet_gpu::testing::accuracy(&c))
}

/// The MaterialX libraries of the user's installation; `None` (with a printed reason) when
/// they are missing, a panic when `CI` is set (`.ci/run` installs them).
pub fn mtlx_library() -> Option<&'static shadenet::graph::mtlx::Library> {
    match shadenet::mtlx::locate(None).and_then(|d| shadenet::mtlx::library(&d)) {
        Ok(l) => Some(l),
        Err(e) if std::env::var_os("CI").is_some() => {
            panic!(
                "CI needs the MaterialX libraries: {}",
                shadenet::graph::error_chain(&e)
            )
        }
        Err(e) => {
            eprintln!("skipped: {}", shadenet::graph::error_chain(&e));
            None
        }
    }
}

/// Renders the example scene `name` (in `examples/scenes/`) at `spp` and `res` on the
/// interpreter and on the JIT; the films in that order.
pub fn render_interp_and_jit(name: &str, spp: u32, res: (u32, u32)) -> [shadenet::tracer::Film; 2] {
    use shadenet::render::{self as r, BackendKind, RenderOptions};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/scenes")
        .join(name);
    let opts = RenderOptions {
        spp: Some(spp),
        res: Some(res),
        ..RenderOptions::default()
    };
    [BackendKind::Interp, BackendKind::Jit].map(|kind| {
        let backend = r::backend(kind).unwrap();
        let renderer = r::setup_with(Some(&path), &opts, backend.as_ref()).unwrap();
        renderer.render(&|_, _| {}).0
    })
}

/// The bits of a film's first layer (the beauty).
pub fn beauty_bits(f: &shadenet::tracer::Film) -> Vec<u32> {
    f.layers[0].data.iter().map(|x| x.to_bits()).collect()
}

/// Compiles the first shader of `src` (a source in `dialect`, named `t.sl` or `t.osl` in
/// messages) to its IR program; `Err` is the rendered diagnostics.
pub fn compile_shader(src: &str, dialect: shadenet::lang::Dialect) -> Result<Program, String> {
    use shadenet::lang::{Dialect, Options, SourceMap, lower, parse_str};
    let mut sources = SourceMap::new();
    let name = if dialect == Dialect::Osl {
        "t.osl"
    } else {
        "t.sl"
    };
    let parsed = parse_str(&mut sources, name, src, &Options::new(dialect))
        .map_err(|d| d.render(&sources))?;
    lower::compile(&parsed, None).map_err(|d| d.render(&sources))
}

/// Shades `program` (optimized for the default specialization) on a `w × h` grid with the
/// interpreter in f32 and with the JIT's scalar and batch entries, asserts that all three
/// give the same bits, and returns them (every pixel's values as f32 bits).
pub fn assert_jit_is_interp(program: &Program, w: u32, h: u32) -> Vec<u32> {
    use shadenet_runtime::Backend;
    let env = shadenet::shade::grid_env(&[]);
    let spec = shadenet_graph::opt::Specialization::default();
    let (o, _) = shadenet_graph::opt::run(program, &spec);
    let interp = shadenet::shade::shade_grid::<f32>(&o, &env, w, h, spec.components).unwrap();
    let m = shadenet_jit::JitBackend::new()
        .compile(program, &spec)
        .unwrap();
    let bits = |v: Vec<f64>| v.iter().map(|x| (*x as f32).to_bits()).collect::<Vec<_>>();
    let want = bits(interp.pixel_values());
    for batch in [false, true] {
        let g = shadenet::shade::shade_grid_with(&*m, &env, w, h, spec.components, batch);
        assert_eq!(want, bits(g.pixel_values()), "JIT batch entry {batch}");
    }
    want
}

/// Runs OSL `body` (which assigns `output color out`) at the plane fragment: the f64 and the
/// f32 values.
pub fn shade_osl_body(body: &str) -> (Vec<f64>, Vec<f64>) {
    let src = format!("shader s(output color out = 0) {{ {body} }}");
    let p =
        compile_shader(&src, shadenet::lang::Dialect::Osl).unwrap_or_else(|e| panic!("{e}\n{src}"));
    let o = run_program(&p, &plane_fragment(), &[], u32::MAX);
    (o.get("out"), o.get32("out"))
}

/// [`shade_osl_body`]'s values within `tol` of `want` (f32 within at least 2e-6).
pub fn osl_close(body: &str, want: [f64; 3], tol: f64) {
    let (a, b) = shade_osl_body(body);
    assert_close(&a, &want, tol, &format!("{body} (f64)"));
    assert_close(&b, &want, tol.max(2e-6), &format!("{body} (f32)"));
}

//! MaterialX's own OSL implementations of its nodes (the `genosl` target of the user's
//! MaterialX libraries, read at run time, never copied), compiled by our OSL front end the
//! way MaterialX's OSL generator uses them (issue 22): for a nodedef whose implementation is
//! a function in a file, a shader that includes `mx_funcs.h` and the file and calls the
//! function with the nodedef's inputs (as parameters with the nodedef's defaults) and
//! outputs; for an inline `sourcecode` template, a shader whose output is the template with
//! `{{input}}` replaced by the parameters. Inputs bound to geometry (`defaultgeomprop`)
//! read our globals. MaterialX's types map onto ours (`color3` → `color`, `vector3` →
//! `vector`, `integer` and `boolean` → `int`, `matrix33` and `matrix44` → `matrix`, a
//! matrix33 being the 4×4 with the 3×3 in its corner, as MaterialX's OSL syntax has it) or
//! onto the structs of its OSL headers (`color4`, `vector2`, `vector4`) and of the
//! generator's preamble (`filename` → `textureresource`). The generator's tokens in the
//! implementation files ([`TOKENS`]: `$fileTransformUv`) are substituted as it does.
//!
//! It owns building these shaders; the language is `shadenet-lang`'s and the nodedefs the
//! library's ([`crate::mtlx`]).

use shadenet_graph::mtlx::Library;
use shadenet_graph::mtlx::document::{CodeImpl, Input, NodeDefElem};
use std::path::{Path, PathBuf};

/// The library folders holding `genosl` implementations.
const FOLDERS: &[&str] = &["stdlib/genosl", "pbrlib/genosl"];

/// What MaterialX's OSL generator defines before every shader (its type definitions
/// included: a `filename` is a `textureresource`, the file's name and colour space).
const PREAMBLE: &str = "#define M_FLOAT_EPS 1e-8\n\
    #define BSDF closure color\n#define EDF closure color\n#define VDF closure color\n\
    struct surfaceshader { closure color bsdf; closure color edf; float opacity; };\n\
    #define volumeshader closure color\n#define displacementshader vector\n\
    #define lightshader closure color\n#define material closure color\n\
    #define MATERIAL closure color\n\
    struct textureresource { string filename; string colorspace; };\n";

/// The tokens MaterialX's OSL generator substitutes in the implementations' source text
/// before compiling it, and their values. `$fileTransformUv` names the file defining
/// `mx_transform_uv`: the generator takes `mx_transform_uv_vflip.osl` when its option
/// `fileTextureVerticalFlip` is set, and we always do: our OSL `texture(f, s, t)` reads
/// `(s, 1 − t)` (OSL's `t` runs down the image) while MaterialX's `v` runs up it, so
/// `t = 1 − v` reads the texel our native image atoms read at `(u, v)`.
pub const TOKENS: &[(&str, &str)] = &[("$fileTransformUv", "mx_transform_uv_vflip.osl")];

/// One `genosl` implementation and the folder its file is relative to.
#[derive(Clone, Debug)]
pub struct GenOsl {
    /// The implementation element.
    pub imp: CodeImpl,
    /// The folder of the document that declares it.
    pub dir: PathBuf,
}

/// Every `genosl` implementation in the libraries at `libraries`, in file order.
pub fn implementations(libraries: &Path) -> Result<Vec<GenOsl>, String> {
    let mut out = Vec::new();
    for folder in FOLDERS {
        let dir = libraries.join(folder);
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        let mut files: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "mtlx"))
            .collect();
        files.sort();
        for f in files {
            let text = std::fs::read_to_string(&f).map_err(|e| format!("{}: {e}", f.display()))?;
            let doc = shadenet_graph::mtlx::parse(&f.display().to_string(), &text)
                .map_err(|e| e.to_string())?;
            out.extend(
                doc.code
                    .into_iter()
                    .filter(|c| c.target == "genosl")
                    .map(|imp| GenOsl {
                        imp,
                        dir: dir.clone(),
                    }),
            );
        }
    }
    Ok(out)
}

/// Our OSL type for a MaterialX type, or `None` where there is none.
fn osl_type(mx: &str) -> Option<&'static str> {
    Some(match mx {
        "float" => "float",
        "integer" | "boolean" => "int",
        "color3" => "color",
        "color4" => "color4",
        "vector2" => "vector2",
        "vector3" => "vector",
        "vector4" => "vector4",
        // MaterialX's OSL generator writes a matrix33 as OSL's 4×4 `matrix` (its functions
        // take `matrix` for matrix33 inputs: `mx_extract_matrix33(matrix in, …)`).
        "matrix33" => "matrix",
        "matrix44" => "matrix",
        "string" => "string",
        "filename" => "textureresource",
        "surfaceshader" => "surfaceshader",
        "displacementshader" => "vector",
        "BSDF" | "EDF" | "VDF" | "volumeshader" | "lightshader" | "material" => "closure color",
        _ => return None,
    })
}

/// The OSL expression of a MaterialX value string of type `mx`.
fn osl_value(mx: &str, value: &str) -> Option<String> {
    let nums: Vec<&str> = value.split(',').map(str::trim).collect();
    let list = || nums.join(", ");
    Some(match mx {
        "float" => nums.first()?.to_string(),
        "integer" => nums.first()?.to_string(),
        "boolean" => (if value.trim() == "true" { "1" } else { "0" }).to_string(),
        "color3" => format!("color({})", list()),
        "vector3" => format!("vector({})", list()),
        "vector2" => format!("vector2({})", list()),
        "vector4" => format!("vector4({})", list()),
        "color4" if nums.len() == 4 => {
            format!(
                "color4(color({}, {}, {}), {})",
                nums[0], nums[1], nums[2], nums[3]
            )
        }
        // A matrix33 is OSL's 4×4 with the 3×3 in its corner (the last row and column of
        // the identity), as MaterialX's OSL syntax writes it: a `matrix` takes 1 or 16 floats.
        "matrix33" if nums.len() == 9 => {
            let row = |r: usize| {
                format!(
                    "{}, {}, {}, 0",
                    nums[3 * r],
                    nums[3 * r + 1],
                    nums[3 * r + 2]
                )
            };
            format!("matrix({}, {}, {}, 0, 0, 0, 1)", row(0), row(1), row(2))
        }
        "matrix44" => format!("matrix({})", list()),
        "string" => format!("{value:?}"),
        "filename" => format!("textureresource({value:?}, \"\")"),
        _ => return None,
    })
}

/// The value an input bound to geometry reads (`defaultgeomprop`).
fn geomprop(mx: &str, prop: &str) -> Option<String> {
    Some(match (prop, mx) {
        ("UV0", "vector2") => "vector2(u, v)".into(),
        ("Nworld" | "Nobject", _) => "N".into(),
        ("Pworld" | "Pobject", _) => "P".into(),
        ("Tworld" | "Tobject", _) => "normalize(dPdu)".into(),
        ("Bworld" | "Bobject", _) => "normalize(dPdv)".into(),
        _ => return None,
    })
}

/// A parameter name for input `name` (prefixed: MaterialX's inputs may be OSL keywords).
fn param_name(name: &str) -> String {
    format!("in_{name}")
}

/// The OSL shader that runs implementation `g` of `nd`, named `mx_<nodedef>`.
pub fn shader_source(g: &GenOsl, nd: &NodeDefElem) -> Result<String, String> {
    shader_source_with(g, nd, &[])
}

/// [`shader_source`] with some inputs' values given (MaterialX value strings by input
/// name) instead of the nodedef's defaults.
pub fn shader_source_with(
    g: &GenOsl,
    nd: &NodeDefElem,
    values: &[(String, String)],
) -> Result<String, String> {
    let mut params = Vec::new();
    for i in &nd.inputs {
        match values.iter().find(|(n, _)| *n == i.name) {
            Some((_, v)) => {
                let mut given = i.clone();
                given.value = Some(v.clone());
                given.defaultgeomprop = None;
                params.push(input_param(&given)?);
            }
            None => params.push(input_param(i)?),
        }
    }
    let (params, outs) = with_outputs(nd, params)?;
    let (include, shader) = shader_parts(g, nd, params, &outs)?;
    let mut src = String::from(PREAMBLE);
    src += "#include \"mx_funcs.h\"\n";
    if let Some(file) = include {
        src += &format!("#include \"{}\"\n", file.display());
    }
    src += &shader;
    Ok(src)
}

/// A `surfaceshader` with no BSDF and no EDF, opaque (MaterialX's OSL default).
const EMPTY_SURFACE: &str = "surfaceshader(0, 0, 1)";

/// `params` followed by the nodedef's outputs as `output` parameters, and the outputs'
/// names.
fn with_outputs(
    nd: &NodeDefElem,
    mut params: Vec<String>,
) -> Result<(Vec<String>, Vec<String>), String> {
    let mut outs = Vec::new();
    for o in &nd.outputs {
        let ty = osl_type(&o.ty).ok_or_else(|| format!("output type `{}`", o.ty))?;
        let name = format!("out_{}", o.name);
        // A surfaceshader output is the shader's closure (see `surface_output`).
        let (ty, init) = match ty {
            "closure color" | "surfaceshader" => ("closure color", "0".to_string()),
            _ => (ty, zero(ty)),
        };
        params.push(format!("output {ty} {name} = {init}"));
        outs.push(name);
    }
    Ok((params, outs))
}

/// The statements around a call whose output `out` is a `surfaceshader`: a local struct the
/// function fills, then the closure it renders as, as `surfacematerial` makes it — `(bsdf +
/// edf)` weighted by the clamped opacity, the rest `transparent()`.
fn surface_output(out: &str) -> (String, String, String) {
    let local = format!("{out}_s");
    let before = format!("    surfaceshader {local} = {EMPTY_SURFACE};\n");
    let after = format!(
        "    float {local}_w = clamp({local}.opacity, 0.0, 1.0);\n    \
         {out} = ({local}.bsdf + {local}.edf) * {local}_w + transparent() * (1.0 - {local}_w);\n"
    );
    (local, before, after)
}

/// The file a shader for `g` includes (if any) and the shader's own text.
fn shader_parts(
    g: &GenOsl,
    nd: &NodeDefElem,
    params: Vec<String>,
    outs: &[String],
) -> Result<(Option<PathBuf>, String), String> {
    let mut include = None;
    let body = match (&g.imp.file, &g.imp.function, &g.imp.sourcecode) {
        (Some(file), Some(function), _) => {
            include = Some(g.dir.join(file));
            let (mut before, mut after) = (String::new(), String::new());
            let mut args: Vec<String> = nd.inputs.iter().map(|i| param_name(&i.name)).collect();
            for (o, name) in nd.outputs.iter().zip(outs) {
                if o.ty == "surfaceshader" {
                    let (local, b, a) = surface_output(name);
                    (before, after) = (before + &b, after + &a);
                    args.push(local);
                } else {
                    args.push(name.clone());
                }
            }
            format!("{before}    {function}({});\n{after}", args.join(", "))
        }
        (_, _, Some(code)) => {
            let mut expr = code.clone();
            for i in &nd.inputs {
                expr = expr.replace(&format!("{{{{{}}}}}", i.name), &param_name(&i.name));
            }
            if expr.contains("{{") {
                return Err(format!("template token left in `{expr}`"));
            }
            let [out] = outs else {
                return Err("an inline template with several outputs".into());
            };
            if nd.outputs[0].ty == "surfaceshader" {
                let (local, before, after) = surface_output(out);
                format!("{before}    {local} = {expr};\n{after}")
            } else {
                format!("    {out} = {expr};\n")
            }
        }
        _ => return Err("neither a function in a file nor a template".into()),
    };
    let shader = format!(
        "shader mx_{}(\n    {})\n{{\n{body}}}\n",
        nd.name,
        params.join(",\n    ")
    );
    Ok((include, shader))
}

fn zero(ty: &str) -> String {
    match ty {
        "float" => "0".into(),
        "int" => "0".into(),
        "color" | "vector" => format!("{ty}(0)"),
        "color4" => "color4(color(0), 0)".into(),
        "vector2" => "vector2(0, 0)".into(),
        "vector4" => "vector4(0, 0, 0, 0)".into(),
        "matrix" => "matrix(0)".into(),
        "string" => "\"\"".into(),
        "textureresource" => "textureresource(\"\", \"\")".into(),
        _ => "0".into(),
    }
}

/// The shader parameter of nodedef input `i`.
fn input_param(i: &Input) -> Result<String, String> {
    let ty = osl_type(&i.ty).ok_or_else(|| format!("input type `{}`", i.ty))?;
    if ty == "closure color" {
        return Ok(format!("closure color {} = 0", param_name(&i.name)));
    }
    if ty == "surfaceshader" {
        return Ok(format!(
            "surfaceshader {} = {EMPTY_SURFACE}",
            param_name(&i.name)
        ));
    }
    let default = match (&i.defaultgeomprop, &i.value) {
        (Some(g), _) => geomprop(&i.ty, g).unwrap_or_else(|| zero(ty)),
        (None, Some(v)) => osl_value(&i.ty, v).unwrap_or_else(|| zero(ty)),
        (None, None) => zero(ty),
    };
    Ok(format!("{ty} {} = {default}", param_name(&i.name)))
}

/// Compiles implementation `g` of `nd` through our OSL front end (include folders: the
/// library's `genosl/include`, its `genosl`, and `stdlib/genosl` for the shared headers).
pub fn compile(
    libraries: &Path,
    g: &GenOsl,
    nd: &NodeDefElem,
) -> Result<shadenet_graph::ir::Program, String> {
    compile_with(libraries, g, nd, &[])
}

/// [`compile`] with some inputs' values given ([`shader_source_with`]).
pub fn compile_with(
    libraries: &Path,
    g: &GenOsl,
    nd: &NodeDefElem,
    values: &[(String, String)],
) -> Result<shadenet_graph::ir::Program, String> {
    let src = shader_source_with(g, nd, values)?;
    let mut sources = shadenet_lang::SourceMap::new();
    if let Some(file) = &g.imp.file {
        substitute_tokens(&mut sources, &g.dir.join(file))?;
    }
    let options = options(libraries, Some(&g.dir));
    let name = format!("mx_{}.osl", nd.name);
    let parsed = shadenet_lang::parse_str(&mut sources, &name, &src, &options)
        .map_err(|d| d.render(&sources))?;
    shadenet_lang::lower::compile(&parsed, None).map_err(|d| d.render(&sources))
}

/// The nodedef an implementation is for, from `lib`.
pub fn nodedef<'l>(lib: &'l Library, g: &GenOsl) -> Option<&'l NodeDefElem> {
    lib.nodedef(&g.imp.nodedef)
}

/// One OSL source holding the shaders of every implementation in `impls` whose nodedef
/// `lib` has (the headers and each file included once), and the shaders' names by
/// nodedef: compiling them all parses the shared headers once.
pub fn module_source(impls: &[GenOsl], lib: &Library) -> (String, Vec<(String, String)>) {
    let mut src = String::from(PREAMBLE);
    src += "#include \"mx_funcs.h\"\n";
    let mut included: Vec<PathBuf> = Vec::new();
    let mut shaders = String::new();
    let mut names = Vec::new();
    for g in impls {
        let Some(nd) = nodedef(lib, g) else {
            continue;
        };
        let Ok(params) = nd
            .inputs
            .iter()
            .map(input_param)
            .collect::<Result<Vec<_>, _>>()
        else {
            continue;
        };
        let Ok((params, outs)) = with_outputs(nd, params) else {
            continue;
        };
        let Ok((include, shader)) = shader_parts(g, nd, params, &outs) else {
            continue;
        };
        if let Some(f) = include
            && !included.contains(&f)
        {
            src += &format!("#include \"{}\"\n", f.display());
            included.push(f);
        }
        shaders += &shader;
        names.push((nd.name.clone(), format!("mx_{}", nd.name)));
    }
    src += &shaders;
    (src, names)
}

/// Parses [`module_source`] once (include folders as [`compile`]'s; the implementations'
/// files of `impls` with the generator's tokens substituted).
pub fn parse_module(
    libraries: &Path,
    impls: &[GenOsl],
    source: &str,
    sources: &mut shadenet_lang::SourceMap,
) -> Result<shadenet_lang::Parsed, String> {
    for g in impls {
        if let Some(file) = &g.imp.file {
            substitute_tokens(sources, &g.dir.join(file))?;
        }
    }
    let options = options(libraries, None);
    shadenet_lang::parse_str(sources, "mx_genosl_module.osl", source, &options)
        .map_err(|d| d.render(sources))
}

/// Loads the file at `path` into `sources` with the generator's [`TOKENS`] substituted, when
/// it holds one (the front end then reads it from `sources` where it is included, as it
/// does every file already there).
fn substitute_tokens(sources: &mut shadenet_lang::SourceMap, path: &Path) -> Result<(), String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    if !TOKENS.iter().any(|(t, _)| text.contains(t)) {
        return Ok(());
    }
    let canon = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    if sources.find(&canon).is_some() {
        return Ok(());
    }
    let text = TOKENS
        .iter()
        .fold(text, |t, (token, value)| t.replace(token, value));
    sources.add(canon, text);
    Ok(())
}

/// The front end's options for MaterialX's OSL: OSL, and the include folders of
/// `stdlib/genosl` (its headers, its sources, `lib`), then `extra` (an implementation's own
/// folder).
fn options(libraries: &Path, extra: Option<&Path>) -> shadenet_lang::Options {
    let stdlib = libraries.join("stdlib/genosl");
    let mut include_dirs = vec![stdlib.join("include"), stdlib.clone(), stdlib.join("lib")];
    include_dirs.extend(extra.map(Path::to_path_buf));
    shadenet_lang::Options {
        dialect: Some(shadenet_lang::Dialect::Osl),
        include_dirs,
        ..shadenet_lang::Options::default()
    }
}

/// The implementations in `libraries` that compile one by one (what [`module_source`]
/// should hold: a parse error in one file would stop the module's parse).
pub fn compiling(libraries: &Path, lib: &Library) -> Result<Vec<GenOsl>, String> {
    Ok(implementations(libraries)?
        .into_iter()
        .filter(|g| nodedef(lib, g).is_some_and(|nd| compile(libraries, g, nd).is_ok()))
        .collect())
}

//! `shadenet gen`: generated networks for the benchmarks, the procedural sky map, the
//! test texture and the vertex-coloured mesh.

use anyhow::{Context, Result, bail};
use clap::{Subcommand, ValueEnum};
use shadenet::graph::ir::Space;
use shadenet::output::write_bytes_atomic;
use std::path::PathBuf;

/// What `shadenet gen` writes.
#[derive(Subcommand)]
pub(crate) enum GenCmd {
    /// The multiplication tree of benchmark B1 (Larsson 2005, §5.1.1): 2^N − 1 multiply nodes
    /// over 2^N samplerInfo leaves whose P feeds the bottom row; the root is output `color`.
    MultTree {
        /// Tree levels N, 1 to 16.
        #[arg(long)]
        levels: u32,
        /// The space the leaves read P in.
        #[arg(long, value_enum, default_value_t = GenSpace::World)]
        space: GenSpace,
        /// The file to write: a network (.json), the same tree as an RSL surface shader
        /// (.sl, world space) or as an OSL shader group (.oslgroup, world space; its
        /// shaders mt_leaf.osl and mt_mult.osl are written beside it).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// A procedural lat-long sky (gradient, small bright sun disc with a glow, darker
    /// ground) as a Radiance .hdr environment map; the defaults make
    /// examples/scenes/pbr_sky.hdr.
    Sky {
        /// Width in texels.
        #[arg(long, default_value_t = 256)]
        width: u32,
        /// Height in texels.
        #[arg(long, default_value_t = 128)]
        height: u32,
        /// Sun elevation above the horizon, degrees (-90 to 90).
        #[arg(long, default_value_t = 35.0, allow_negative_numbers = true)]
        sun_elevation: f64,
        /// Sun azimuth, degrees: 0 at the map's centre column (-z), 90 at +x.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        sun_azimuth: f64,
        /// Sun disc angular radius, degrees (above 0, at most 45).
        #[arg(long, default_value_t = 2.0)]
        sun_radius: f64,
        /// Sun disc radiance.
        #[arg(long, default_value_t = 1000.0)]
        sun_radiance: f64,
        /// The map file to write (.hdr).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// The 2048² test texture of examples/scenes/texture_plane.toml (sRGB PNG: checks, hues
    /// and thin lines at every scale); the default makes examples/scenes/textures/grid.png.
    Texture {
        /// The image file to write (.png).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// A plane with vertex colours as a Wavefront OBJ (`v x y z r g b`, read as attribute
    /// COLOR_0); it makes examples/scenes/meshes/vertex_colors.obj.
    VertexColors {
        /// The mesh file to write (.obj).
        #[arg(short, long)]
        output: PathBuf,
    },
}

/// The space the tree's leaves read P in.
#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum GenSpace {
    /// World space.
    World,
    /// Camera space.
    Camera,
}

/// Runs `shadenet gen`.
pub(crate) fn run(what: GenCmd) -> Result<()> {
    match what {
        GenCmd::MultTree {
            levels,
            space,
            output,
        } => {
            let space = match space {
                GenSpace::World => Space::World,
                GenSpace::Camera => Space::Camera,
            };
            // `-o tree.sl`: the same tree written as an RSL surface shader; `-o
            // tree.oslgroup`: as an OSL shader group, its two shaders written beside it.
            let group = output
                .extension()
                .is_some_and(|e| e == shadenet::shader::GROUP_EXTENSION);
            let text = if group {
                if !matches!(space, Space::World) {
                    bail!("--space camera: the group form reads P in world space only");
                }
                let dir = output.parent().unwrap_or(std::path::Path::new(""));
                for (name, source) in shadenet::generate::MULT_TREE_SHADERS {
                    write_bytes_atomic(&dir.join(name), source.as_bytes())?;
                }
                shadenet::generate::mult_tree_group(levels).context("--levels")?
            } else if output.extension().is_some_and(|e| e == "sl") {
                if !matches!(space, Space::World) {
                    bail!("--space camera: the shader form reads P in world space only");
                }
                shadenet::generate::mult_tree_sl(levels).context("--levels")?
            } else {
                let net = shadenet::generate::mult_tree(levels, space).context("--levels")?;
                let mut text = serde_json::to_string_pretty(&net)?;
                text.push('\n');
                text
            };
            write_bytes_atomic(&output, text.as_bytes())?;
            Ok(())
        }
        GenCmd::Sky {
            width,
            height,
            sun_elevation,
            sun_azimuth,
            sun_radius,
            sun_radiance,
            output,
        } => {
            let sky = shadenet::generate::Sky {
                width,
                height,
                sun_elevation,
                sun_azimuth,
                sun_radius,
                sun_radiance,
            };
            let bytes = shadenet::generate::sky_hdr(&sky)?;
            write_bytes_atomic(&output, &bytes)?;
            Ok(())
        }
        GenCmd::VertexColors { output } => {
            let text = shadenet::generate::vertex_color_obj();
            write_bytes_atomic(&output, text.as_bytes())?;
            Ok(())
        }
        GenCmd::Texture { output } => {
            let bytes = shadenet::generate::test_texture()?;
            write_bytes_atomic(&output, &bytes)?;
            Ok(())
        }
    }
}

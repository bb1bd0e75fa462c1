//! Why a scene cannot be rendered: the one error type of set-up and compiling.

/// Why a scene cannot be rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The scene and the compiled materials do not match.
    #[error("the scene has {scene} materials but {given} programs were given")]
    MaterialCount {
        /// Materials in the scene.
        scene: usize,
        /// Programs given.
        given: usize,
    },
    /// A material could not be compiled by the back end.
    #[error("material `{material}`: {message}")]
    Compile {
        /// The material (or override) name.
        material: String,
        /// Why.
        message: String,
    },
    /// A light shader of the scene was not compiled (the caller compiles
    /// [`crate::scene::Scene::shader_lights`] into lights first).
    #[error(
        "{light}: the light shader {} was not compiled: a scene's light shaders are compiled by the caller (shadenet's render set-up) before the renderer starts",
        file.display()
    )]
    ShaderLight {
        /// The light's key, `lights[i]`.
        light: String,
        /// Its shader file.
        file: std::path::PathBuf,
    },
    /// A pass or rule names an unknown component.
    #[error("{0}")]
    Pass(String),
    /// An instance's transformed vertices are not finite or lie beyond the supported
    /// coordinate range (a scene built by hand; a loaded scene is checked with its keys).
    #[error(
        "instance `{instance}`: {triangles} triangle(s) have a vertex that is not finite or \
         lies outside the supported coordinate range ±{:e}",
        crate::geometry::MAX_COORDINATE
    )]
    Geometry {
        /// The first instance concerned.
        instance: String,
        /// Triangles left out, over all instances.
        triangles: usize,
    },
}

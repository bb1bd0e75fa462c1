//! The textures of a material as the GPU kernels read them: every mip level of every
//! texture in one texel array, and a table of texture headers and level rows
//! (`wgsl/texture.wgsl` documents the layout). Owns the layout only; the texture system
//! (decoding, mipmaps, filters on the CPU) is the runtime's, and this module must not
//! filter or convert anything.

use shadenet_runtime::texture::TextureSet;

/// The contents of `sn_texels` and `sn_tex_info`.
pub type TextureBuffers = (Vec<[f32; 4]>, Vec<[u32; 4]>);

/// `sn_texels` and `sn_tex_info` for `count` texture-table entries of `set` (entries the set
/// does not hold become an empty one-texel image): rows `0..count` of the info are `(first
/// level row, level count, 0, 0)`, the level rows `(first texel, width, height, 0)`. An
/// error names what the GPU back end does not read yet (UDIM tile sets).
pub fn texture_buffers(count: usize, set: &TextureSet) -> Result<TextureBuffers, String> {
    let mut texels: Vec<[f32; 4]> = Vec::new();
    let mut heads: Vec<[u32; 4]> = Vec::with_capacity(count);
    let mut levels: Vec<[u32; 4]> = Vec::new();
    let u32_of = |n: usize, what: &str| {
        u32::try_from(n).map_err(|_| format!("the textures have more {what} than 2^32"))
    };
    for i in 0..count {
        let first = u32_of(count + levels.len(), "levels")?;
        match set.get(i as u32) {
            Some(t) if t.udim_tiles().is_some() => {
                return Err(format!(
                    "texture {i} is a UDIM tile set, which the GPU back end does not read yet"
                ));
            }
            Some(t) => {
                let pyramid = t.pyramid().levels();
                heads.push([first, u32_of(pyramid.len(), "levels")?, 0, 0]);
                for l in pyramid {
                    levels.push([u32_of(texels.len(), "texels")?, l.width, l.height, 0]);
                    texels.extend_from_slice(&l.texels);
                }
            }
            None => {
                heads.push([first, 1, 0, 0]);
                levels.push([u32_of(texels.len(), "texels")?, 1, 1, 0]);
                texels.push([0.0; 4]);
            }
        }
    }
    if texels.is_empty() {
        texels.push([0.0; 4]);
    }
    heads.extend(levels);
    if heads.is_empty() {
        heads.push([0; 4]);
    }
    Ok((texels, heads))
}

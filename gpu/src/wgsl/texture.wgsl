// Texture lookup (sn_texture): being written.

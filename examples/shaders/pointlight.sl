/* pointlight: light from a point, falling off with the square of the distance (RenderMan
   Interface): Cl = intensity * lightcolor / (L . L). RSL intensities are not shadenet's:
   shadenet's point light of intensity I lights a lambert surface with I·ρ/π·cosθ/r², RSL's
   matte under this light gives intensity·Kd·cosθ/r² (no 1/π), so matte under pointlight
   equals lambert under a built-in point light of the same intensity, times π.
   Written for shadenet. */
light pointlight(float intensity = 1; color lightcolor = 1; point from = (0, 0, 0))
{
    illuminate(from)
        Cl = intensity * lightcolor / (L . L);
}

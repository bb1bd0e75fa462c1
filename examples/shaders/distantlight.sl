/* distantlight: parallel light travelling from `from` towards `to` (RenderMan Interface):
   solar(to - from, 0) with Cl = intensity * lightcolor, no falloff. Written for shadenet. */
light distantlight(float intensity = 1; color lightcolor = 1;
                   point from = (0, 0, 0); point to = (0, 0, 1))
{
    solar(to - from, 0)
        Cl = intensity * lightcolor;
}

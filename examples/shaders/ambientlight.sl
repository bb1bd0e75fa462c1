/* ambientlight: light without a direction (RenderMan Interface): Cl = intensity *
   lightcolor, L = 0. shadenet evaluates it once and adds it to ambient(). Written for
   shadenet. */
light ambientlight(float intensity = 1; color lightcolor = 1)
{
    Cl = intensity * lightcolor;
    L = 0;
}

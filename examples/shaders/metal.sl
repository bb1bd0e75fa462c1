/* metal: a specular-only surface tinted by its color (RenderMan Interface):
   Ci = Os * Cs * (Ka * ambient() + Ks * specular(Nf, V, roughness)). Written for shadenet. */
surface metal(float Ka = 1, Ks = 1, roughness = .1; color tint = 1)
{
    normal Nf = faceforward(normalize(N), I);
    vector V = -normalize(I);
    Oi = Os;
    Ci = Os * Cs * tint * (Ka * ambient() + Ks * specular(Nf, V, roughness));
}

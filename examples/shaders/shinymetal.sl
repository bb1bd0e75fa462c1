/* shinymetal: metal plus a mirror reflection (RenderMan Interface), the reflection traced
   through the scene where the original reads an environment map:
   Ci = Os * Cs * (Ka * ambient() + Ks * (specular(Nf, V, roughness) + Kr * trace(P, R))).
   Written for shadenet. */
surface shinymetal(float Ka = 1, Ks = 1, Kr = 1, roughness = .1; color tint = 1)
{
    normal Nf = faceforward(normalize(N), I);
    vector V = -normalize(I);
    vector R = reflect(normalize(I), Nf);
    Oi = Os;
    Ci = Os * Cs * tint * (Ka * ambient() + Ks * (specular(Nf, V, roughness) + Kr * trace(P, R)));
}

/* plastic: a diffuse base under a white highlight (RenderMan Interface):
   Ci = Os * (Cs * (Ka * ambient() + Kd * diffuse(Nf)) + specularcolor * Ks * specular(Nf, V, roughness)).
   Written for shadenet. */
surface plastic(float Ks = .5, Kd = .5, Ka = 1, roughness = .1;
                color specularcolor = 1; color tint = 1)
{
    normal Nf = faceforward(normalize(N), I);
    vector V = -normalize(I);
    Oi = Os;
    Ci = Os * (Cs * tint * (Ka * ambient() + Kd * diffuse(Nf))
               + specularcolor * Ks * specular(Nf, V, roughness));
}

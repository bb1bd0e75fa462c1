/* paintedplastic: plastic whose color is multiplied by a texture map at (s, t)
   (RenderMan Interface). Written for shadenet; the default map is the test texture that
   `shadenet gen texture` makes. */
surface paintedplastic(float Ks = .5, Kd = .5, Ka = 1, roughness = .1;
                       color specularcolor = 1;
                       string texturename = "../scenes/textures/grid.png")
{
    normal Nf = faceforward(normalize(N), I);
    vector V = -normalize(I);
    color Ct = Cs * texture(texturename, s, t);
    Oi = Os;
    Ci = Os * (Ct * (Ka * ambient() + Kd * diffuse(Nf))
               + specularcolor * Ks * specular(Nf, V, roughness));
}

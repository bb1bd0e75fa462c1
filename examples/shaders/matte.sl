/* matte: a Lambertian surface (RenderMan Interface):
   Ci = Os * Cs * (Ka * ambient() + Kd * diffuse(Nf)). RSL's diffuse() has no 1/π: matte is
   π times shadenet's lambert with the same color. Written for shadenet. */
surface matte(float Ka = 1, Kd = 1; color tint = 1)
{
    normal Nf = faceforward(normalize(N), I);
    Oi = Os;
    Ci = Os * Cs * tint * (Ka * ambient() + Kd * diffuse(Nf));
}

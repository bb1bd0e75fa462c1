/* matte: Lambertian diffuse, from the RenderMan Interface's published formula
   Ci = Os * Cs * (Ka * ambient() + Kd * diffuse(Nf)). Written for shadenet's tests. */
surface matte(float Ka = 1, Kd = 1)
{
    normal Nf = faceforward(normalize(N), I);
    Oi = Os;
    Ci = Os * Cs * (Ka * ambient() + Kd * diffuse(Nf));
}

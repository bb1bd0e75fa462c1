/* spotlight: a point light limited to a cone (RenderMan Interface): light within
   `coneangle` of the axis from `from` to `to`, falling off as cos^beamdistribution of the
   angle to the axis and 1/distance², and smoothly to black over the last `conedeltaangle`
   of the cone. Angles in radians (defaults: 30 and 5 degrees). Written for shadenet. */
light spotlight(float intensity = 1; color lightcolor = 1;
                point from = (0, 0, 0); point to = (0, 0, 1);
                float coneangle = 0.5235988; float conedeltaangle = 0.08726646;
                float beamdistribution = 2)
{
    uniform vector A = normalize(to - from);
    uniform float cosoutside = cos(coneangle);
    uniform float cosinside = cos(coneangle - conedeltaangle);
    float atten, cosangle;
    illuminate(from, A, coneangle) {
        cosangle = (L . A) / length(L);
        atten = pow(cosangle, beamdistribution) / (L . L);
        atten *= smoothstep(cosoutside, cosinside, cosangle);
        Cl = atten * intensity * lightcolor;
    }
}

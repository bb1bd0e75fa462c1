/* constant: the surface's own color, unlit (RenderMan Interface: Oi = Os; Ci = Os * Cs).
   Written for shadenet from the published formula. */
surface constant(color tint = 1)
{
    Oi = Os;
    Ci = Os * Cs * tint;
}

/* Loops for the front end's fuzz target: for, while, break, continue, break 2, nesting. */
surface loops(float n = 6)
{
    uniform float i;
    float j, sum = 0, k = 0;
    for (i = 0; i < n; i += 1) {
        if (i == 2) continue;
        for (j = 0; j < i; j += 1) {
            if (j * i > 8) break 2;
            sum += noise(P * j);
        }
    }
    while (k < s * 10) { k += 1; if (k > 7) break; }
    Ci = color(sum, k, i);
}

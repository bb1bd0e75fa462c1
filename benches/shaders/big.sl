/* big.sl: a 500-line RSL surface shader of our own for the front-end benchmark (issue 21:
   front end + optimize + JIT <= 20 ms on one thread). Small pattern functions, a layered
   surface calling them, conditionals and light loops; no loops (not built yet). */

float band0(float x; float y)
{
    float a = abs(x * 1.882) + 0.192;
    float b = cos(y * 0.192 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint1(color c; float t)
{
    color warm = color "rgb" (0.66, 0.22, 0.27);
    color cool = color "rgb" (0.13, 0.25, 0.6);
    float w = smoothstep(0.052, 0.552, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 0.21 * c;
}

vector warp2(point p; float amount)
{
    float n = noise(p * 3.816);
    vector d = vector "world" (floor(n * 1.298), sin(n + 1.298), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 1.298;
}

float band3(float x; float y)
{
    float a = floor(x * 2.52) + 0.854;
    float b = sin(y * 0.854 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint4(color c; float t)
{
    color warm = color "rgb" (0.59, 0.52, 0.33);
    color cool = color "rgb" (0.32, 0.61, 0.37);
    float w = smoothstep(0.088, 0.588, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 0.353 * c;
}

vector warp5(point p; float amount)
{
    float n = noise(p * 1.803);
    vector d = vector "world" (floor(n * 1.141), cos(n + 1.141), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 1.141;
}

float band6(float x; float y)
{
    float a = sin(x * 0.709) + 0.491;
    float b = floor(y * 0.491 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint7(color c; float t)
{
    color warm = color "rgb" (0.95, 0.42, 0.2);
    color cool = color "rgb" (0.17, 0.67, 0.36);
    float w = smoothstep(0.246, 0.746, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 0.985 * c;
}

vector warp8(point p; float amount)
{
    float n = noise(p * 2.233);
    vector d = vector "world" (abs(n * 0.753), floor(n + 0.753), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 0.753;
}

float band9(float x; float y)
{
    float a = sqrt(x * 2.631) + 0.239;
    float b = abs(y * 0.239 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint10(color c; float t)
{
    color warm = color "rgb" (0.95, 0.45, 0.48);
    color cool = color "rgb" (0.13, 0.53, 0.85);
    float w = smoothstep(0.188, 0.688, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 0.75 * c;
}

vector warp11(point p; float amount)
{
    float n = noise(p * 2.934);
    vector d = vector "world" (abs(n * 1.229), abs(n + 1.229), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 1.229;
}

float band12(float x; float y)
{
    float a = floor(x * 0.741) + 0.278;
    float b = sqrt(y * 0.278 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint13(color c; float t)
{
    color warm = color "rgb" (0.81, 0.39, 0.33);
    color cool = color "rgb" (0.37, 0.47, 0.8);
    float w = smoothstep(0.056, 0.556, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 0.223 * c;
}

vector warp14(point p; float amount)
{
    float n = noise(p * 3.792);
    vector d = vector "world" (abs(n * 0.775), sin(n + 0.775), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 0.775;
}

float band15(float x; float y)
{
    float a = floor(x * 2.228) + 0.515;
    float b = sin(y * 0.515 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint16(color c; float t)
{
    color warm = color "rgb" (0.94, 0.5, 0.17);
    color cool = color "rgb" (0.26, 0.37, 0.4);
    float w = smoothstep(0.214, 0.714, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 0.856 * c;
}

vector warp17(point p; float amount)
{
    float n = noise(p * 1.474);
    vector d = vector "world" (sqrt(n * 0.889), floor(n + 0.889), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 0.889;
}

float band18(float x; float y)
{
    float a = abs(x * 3.852) + 0.387;
    float b = sqrt(y * 0.387 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint19(color c; float t)
{
    color warm = color "rgb" (0.64, 0.55, 0.21);
    color cool = color "rgb" (0.1, 0.45, 0.56);
    float w = smoothstep(0.136, 0.636, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 0.543 * c;
}

vector warp20(point p; float amount)
{
    float n = noise(p * 3.836);
    vector d = vector "world" (floor(n * 1.412), abs(n + 1.412), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 1.412;
}

float band21(float x; float y)
{
    float a = floor(x * 2.792) + 1.506;
    float b = floor(y * 1.506 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint22(color c; float t)
{
    color warm = color "rgb" (0.37, 0.58, 0.12);
    color cool = color "rgb" (0.13, 0.33, 0.41);
    float w = smoothstep(0.214, 0.715, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 0.858 * c;
}

vector warp23(point p; float amount)
{
    float n = noise(p * 0.684);
    vector d = vector "world" (abs(n * 0.1), floor(n + 0.1), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 0.1;
}

float band24(float x; float y)
{
    float a = cos(x * 0.855) + 0.791;
    float b = floor(y * 0.791 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint25(color c; float t)
{
    color warm = color "rgb" (0.4, 0.35, 0.24);
    color cool = color "rgb" (0.25, 0.27, 0.89);
    float w = smoothstep(0.317, 0.817, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 1.267 * c;
}

vector warp26(point p; float amount)
{
    float n = noise(p * 2.193);
    vector d = vector "world" (sqrt(n * 0.263), sqrt(n + 0.263), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 0.263;
}

float band27(float x; float y)
{
    float a = sin(x * 3.091) + 1.009;
    float b = abs(y * 1.009 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint28(color c; float t)
{
    color warm = color "rgb" (0.67, 0.29, 0.32);
    color cool = color "rgb" (0.11, 0.52, 0.98);
    float w = smoothstep(0.477, 0.977, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 1.907 * c;
}

vector warp29(point p; float amount)
{
    float n = noise(p * 2.314);
    vector d = vector "world" (sin(n * 1.826), abs(n + 1.826), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 1.826;
}

float band30(float x; float y)
{
    float a = abs(x * 2.364) + 1.58;
    float b = cos(y * 1.58 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint31(color c; float t)
{
    color warm = color "rgb" (0.83, 0.32, 0.2);
    color cool = color "rgb" (0.26, 0.68, 0.44);
    float w = smoothstep(0.400, 0.899, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 1.598 * c;
}

vector warp32(point p; float amount)
{
    float n = noise(p * 3.059);
    vector d = vector "world" (sqrt(n * 1.98), abs(n + 1.98), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 1.98;
}

float band33(float x; float y)
{
    float a = abs(x * 1.407) + 1.416;
    float b = sqrt(y * 1.416 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint34(color c; float t)
{
    color warm = color "rgb" (0.54, 0.78, 0.13);
    color cool = color "rgb" (0.14, 0.48, 0.54);
    float w = smoothstep(0.368, 0.869, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 1.474 * c;
}

vector warp35(point p; float amount)
{
    float n = noise(p * 3.948);
    vector d = vector "world" (sqrt(n * 1.259), floor(n + 1.259), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 1.259;
}

float band36(float x; float y)
{
    float a = sin(x * 3.682) + 0.754;
    float b = sqrt(y * 0.754 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint37(color c; float t)
{
    color warm = color "rgb" (0.83, 0.49, 0.17);
    color cool = color "rgb" (0.42, 0.4, 0.86);
    float w = smoothstep(0.397, 0.897, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 1.586 * c;
}

vector warp38(point p; float amount)
{
    float n = noise(p * 1.905);
    vector d = vector "world" (sqrt(n * 1.899), sqrt(n + 1.899), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 1.899;
}

float band39(float x; float y)
{
    float a = cos(x * 3.976) + 0.152;
    float b = cos(y * 0.152 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint40(color c; float t)
{
    color warm = color "rgb" (0.88, 0.79, 0.36);
    color cool = color "rgb" (0.24, 0.53, 0.39);
    float w = smoothstep(0.095, 0.595, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 0.378 * c;
}

vector warp41(point p; float amount)
{
    float n = noise(p * 2.343);
    vector d = vector "world" (sin(n * 1.874), sin(n + 1.874), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 1.874;
}

float band42(float x; float y)
{
    float a = sqrt(x * 3.392) + 0.501;
    float b = cos(y * 0.501 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint43(color c; float t)
{
    color warm = color "rgb" (0.71, 0.36, 0.27);
    color cool = color "rgb" (0.15, 0.75, 0.55);
    float w = smoothstep(0.139, 0.639, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 0.557 * c;
}

vector warp44(point p; float amount)
{
    float n = noise(p * 3.353);
    vector d = vector "world" (sqrt(n * 1.082), floor(n + 1.082), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 1.082;
}

float band45(float x; float y)
{
    float a = floor(x * 2.361) + 1.095;
    float b = cos(y * 1.095 + a);
    float c = smoothstep(0, 1, mod(a * b, 1));
    if (c > 0.5) c = 1 - c; else c = c * 2;
    return mix(a, b, clamp(c, 0, 1));
}

color tint46(color c; float t)
{
    color warm = color "rgb" (0.84, 0.29, 0.16);
    color cool = color "rgb" (0.35, 0.27, 0.34);
    float w = smoothstep(0.314, 0.814, t);
    color m = mix(warm, cool, w);
    return c * m + (1 - w) * 1.256 * c;
}

vector warp47(point p; float amount)
{
    float n = noise(p * 2.444);
    vector d = vector "world" (floor(n * 1.59), floor(n + 1.59), n - 0.5);
    float len = length(d);
    if (len > 0) d = d / len;
    return d * amount * 1.59;
}

surface big(float Ka = 1, Kd = 0.6, Ks = 0.4, roughness = 0.15;
            color base = color "rgb" (0.7, 0.55, 0.4);
            color sheen = 1; float scale = 3; float detail = 0.25)
{
    normal Nf = faceforward(normalize(N), I);
    vector V = -normalize(I);
    point p = P * scale;
    float pat = 0;
    color c = base;
    pat += band0(s * scale + 0, t * scale - 0) * 0.014;
    c = tint1(c, pat + 0.56);
    if (pat > 0.35) { c = c * 0.91; pat -= 0.08; }
    p += warp2(p, detail);
    pat += 0.126 * noise(p + vector "world" (2, 3, 4));
    pat += band3(s * scale + 3, t * scale - 3) * 0.032;
    c = tint4(c, pat + 0.76);
    if (pat > 0.75) { c = c * 0.98; pat -= 0.065; }
    p += warp5(p, detail);
    pat += 0.126 * noise(p + vector "world" (5, 6, 7));
    pat += band6(s * scale + 6, t * scale - 6) * 0.03;
    c = tint7(c, pat + 0.693);
    if (pat > 0.47) { c = c * 1.01; pat -= 0.053; }
    p += warp8(p, detail);
    pat += 0.191 * noise(p + vector "world" (8, 9, 10));
    pat += band9(s * scale + 9, t * scale - 9) * 0.038;
    c = tint10(c, pat + 0.877);
    if (pat > 0.77) { c = c * 0.9; pat -= 0.06; }
    p += warp11(p, detail);
    pat += 0.191 * noise(p + vector "world" (11, 12, 13));
    pat += band12(s * scale + 12, t * scale - 12) * 0.044;
    c = tint13(c, pat + 0.137);
    if (pat > 0.27) { c = c * 0.98; pat -= 0.017; }
    p += warp14(p, detail);
    pat += 0.086 * noise(p + vector "world" (14, 15, 16));
    pat += band15(s * scale + 15, t * scale - 15) * 0.013;
    c = tint16(c, pat + 0.669);
    if (pat > 0.67) { c = c * 1.16; pat -= 0.024; }
    p += warp17(p, detail);
    pat += 0.157 * noise(p + vector "world" (17, 18, 19));
    pat += band18(s * scale + 18, t * scale - 18) * 0.036;
    c = tint19(c, pat + 0.143);
    if (pat > 0.73) { c = c * 1.19; pat -= 0.03; }
    p += warp20(p, detail);
    pat += 0.193 * noise(p + vector "world" (20, 21, 22));
    pat += band21(s * scale + 21, t * scale - 21) * 0.026;
    c = tint22(c, pat + 0.487);
    if (pat > 0.79) { c = c * 1.13; pat -= 0.025; }
    p += warp23(p, detail);
    pat += 0.115 * noise(p + vector "world" (23, 24, 25));
    pat += band24(s * scale + 24, t * scale - 24) * 0.031;
    c = tint25(c, pat + 0.339);
    if (pat > 0.32) { c = c * 0.93; pat -= 0.075; }
    p += warp26(p, detail);
    pat += 0.053 * noise(p + vector "world" (26, 27, 28));
    pat += band27(s * scale + 27, t * scale - 27) * 0.032;
    c = tint28(c, pat + 0.44);
    if (pat > 0.21) { c = c * 0.93; pat -= 0.066; }
    p += warp29(p, detail);
    pat += 0.127 * noise(p + vector "world" (29, 30, 31));
    pat += band30(s * scale + 30, t * scale - 30) * 0.013;
    c = tint31(c, pat + 0.985);
    if (pat > 0.67) { c = c * 1.19; pat -= 0.019; }
    p += warp32(p, detail);
    pat += 0.09 * noise(p + vector "world" (32, 33, 34));
    pat += band33(s * scale + 33, t * scale - 33) * 0.012;
    c = tint34(c, pat + 0.779);
    if (pat > 0.36) { c = c * 0.85; pat -= 0.048; }
    p += warp35(p, detail);
    pat += 0.187 * noise(p + vector "world" (35, 36, 37));
    pat += band36(s * scale + 36, t * scale - 36) * 0.043;
    c = tint37(c, pat + 0.259);
    if (pat > 0.29) { c = c * 1.17; pat -= 0.061; }
    p += warp38(p, detail);
    pat += 0.155 * noise(p + vector "world" (38, 39, 40));
    pat += band39(s * scale + 39, t * scale - 39) * 0.014;
    c = tint40(c, pat + 0.058);
    if (pat > 0.61) { c = c * 0.97; pat -= 0.017; }
    p += warp41(p, detail);
    pat += 0.191 * noise(p + vector "world" (41, 42, 43));
    pat += band42(s * scale + 42, t * scale - 42) * 0.035;
    c = tint43(c, pat + 0.802);
    if (pat > 0.25) { c = c * 1.14; pat -= 0.016; }
    p += warp44(p, detail);
    pat += 0.179 * noise(p + vector "world" (44, 45, 46));
    pat += band45(s * scale + 45, t * scale - 45) * 0.028;
    c = tint46(c, pat + 0.339);
    if (pat > 0.53) { c = c * 1.17; pat -= 0.034; }
    p += warp47(p, detail);
    pat += 0.069 * noise(p + vector "world" (47, 48, 49));
    color diff = 0;
    color spec = 0;
    illuminance(P, Nf, PI / 2) {
        vector Ln = normalize(L);
        diff += Cl * max(0, Nf . Ln);
        vector H = normalize(Ln + V);
        spec += Cl * pow(max(0, Nf . H), 1 / roughness);
    }
    color rim = 0;
    illuminance(P) {
        rim += Cl * pow(1 - abs(V . Nf), 3) * 0.1;
    }
    float fres = 0.04 + 0.96 * pow(1 - abs(V . Nf), 5);
    color layer = mix(c, sheen, fres * detail);
    if (pat < 0.3) {
        layer = layer * 0.8;
        spec = spec * 0.5;
    } else if (pat < 0.6) {
        layer = layer * 0.9 + 0.05;
    } else {
        layer = layer + color "hsv" (pat, 0.2, 0.1);
    }
    Oi = Os;
    Ci = Os * (layer * (Ka * ambient() + Kd * diff) + Ks * spec + rim);
}

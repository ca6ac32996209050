#ifndef POST_FEATURES_GLSL
#define POST_FEATURES_GLSL
// The volume's feature buffers (volume/features.comp writes them once per view, the denoiser and
// temporal reuse read them), two 32-bit words per pixel so the current and the previous view's
// fit beside the denoiser's images in 12 floats a pixel:
//   x: ray distance where the camera ray's transmittance first falls below ½, or, where it never
//      does, the expected distance of its first collision (< 0: the ray sees the background
//      through more than 95 % transmittance);
//   y: the gradient normal there (octahedral, 6 + 6 bits; the camera-facing ray direction where
//      the gradient vanishes), the transfer function's albedo there (5 bits a channel) and the
//      transmittance to the background (5 bits).
// Edge-stopping needs no more precision: a 6-bit octahedral normal is within about 2°.
struct Feature { float depth; vec3 normal; vec3 albedo; float transmittance; };

vec2 oct_encode(vec3 n) {
    n /= abs(n.x) + abs(n.y) + abs(n.z);
    vec2 e = n.xy;
    if (n.z < 0.0) e = (1.0 - abs(n.yx)) * vec2(n.x >= 0.0 ? 1.0 : -1.0, n.y >= 0.0 ? 1.0 : -1.0);
    return e;
}

vec3 oct_decode(vec2 e) {
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    float t = max(-n.z, 0.0);
    n.xy += vec2(n.x >= 0.0 ? -t : t, n.y >= 0.0 ? -t : t);
    return normalize(n);
}

uint quantize(float v, float levels) { return uint(clamp(v, 0.0, 1.0) * levels + 0.5); }

uvec2 pack_feature(Feature f) {
    vec2 o = oct_encode(f.normal) * 0.5 + 0.5;
    uint w = quantize(o.x, 63.0) | quantize(o.y, 63.0) << 6;
    w |= quantize(f.albedo.r, 31.0) << 12 | quantize(f.albedo.g, 31.0) << 17 | quantize(f.albedo.b, 31.0) << 22;
    w |= quantize(f.transmittance, 31.0) << 27;
    return uvec2(floatBitsToUint(f.depth), w);
}

Feature unpack_feature(uvec2 v) {
    Feature f;
    f.depth = uintBitsToFloat(v.x);
    uint w = v.y;
    f.normal = oct_decode(vec2(w & 63u, (w >> 6) & 63u) / 63.0 * 2.0 - 1.0);
    f.albedo = vec3(float((w >> 12) & 31u), float((w >> 17) & 31u), float((w >> 22) & 31u)) / 31.0;
    f.transmittance = float(w >> 27) / 31.0;
    return f;
}

const vec3 LUMINANCE = vec3(0.2126, 0.7152, 0.0722);
#endif

#ifndef VOLUME_PHASE_GLSL
#define VOLUME_PHASE_GLSL
// TEMPORARY (replaced by the phase-function work): isotropic and Henyey–Greenstein only.
const float PI = 3.14159265358979;
struct Phase { uint kind; float g; float g2; float w; };
float phase_eval(Phase p, float mu) {
    if (p.kind == 0u || abs(p.g) < 1e-3) return 0.25 / PI;
    float g = clamp(p.g, -0.999, 0.999);
    float d = 1.0 + g * g - 2.0 * g * mu;
    return (1.0 - g * g) / (4.0 * PI * d * sqrt(d));
}
float phase_pdf(Phase p, vec3 wi, vec3 wo) { return phase_eval(p, dot(wi, wo)); }
vec3 phase_sample(Phase p, vec3 wi, vec2 xi, out float pdf) {
    float mu;
    if (p.kind == 0u || abs(p.g) < 1e-3) {
        mu = 1.0 - 2.0 * xi.x;
    } else {
        float g = clamp(p.g, -0.999, 0.999);
        float s = (1.0 - g * g) / (1.0 - g + 2.0 * g * xi.x);
        mu = clamp((1.0 + g * g - s * s) / (2.0 * g), -1.0, 1.0);
    }
    float sin_t = sqrt(max(0.0, 1.0 - mu * mu));
    float phi = 2.0 * PI * xi.y;
    float sgn = wi.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sgn + wi.z);
    float b = wi.x * wi.y * a;
    vec3 t = vec3(1.0 + sgn * wi.x * wi.x * a, sgn * b, -sgn * wi.x);
    vec3 bt = vec3(b, sgn + wi.y * wi.y * a, -wi.y);
    pdf = phase_eval(p, mu);
    return normalize(sin_t * cos(phi) * t + sin_t * sin(phi) * bt + mu * wi);
}
#endif

#ifndef LPV_TRANSFER_GLSL
#define LPV_TRANSFER_GLSL
// The faces of one propagation step (REFERENCE.md). Written out per direction and face with compile-time axes
// (macros the front end folds), so each face touches only the SH coefficients its direction and
// lobe have: sh_basis(ω) = (Y0, −Y1·ω.y, Y1·ω.z, −Y1·ω.x), so axis a's linear coefficient is
// SH_K(a) with sign SH_SGN(a); a face direction has at most two non-zero axes and a lobe one.
// FOR_EACH_DIRECTION(M) expands M(D, A, S, B1, B2) for the six directions in DIRS order
// (D: index, A: axis, S: sign ±1.0, B1 < B2: the other two axes); a face f (0–4, a literal)
// of a direction is, in the thesis' order, the front, +B1, −B1, +B2, −B2.
#include "sh.glsl"

// Solid angles of a neighbour's faces from the source centre: 6 × (front + 4 sides) = 4π
// (REFERENCE.md misprints the side as 0.42344…).
const float FRONT = 0.4006696846;
const float SIDE = 0.4234313544;
// A side face's direction from the source centre, normalize(d + ½·side): its components along d
// and along the side.
const float W_D = 0.8944271910;
const float W_S = 0.4472135955;

#define SH_K(a) ((a) == 0 ? 3 : ((a) == 1 ? 1 : 2))
#define SH_SGN(a) ((a) == 2 ? 1.0 : -1.0)
// SH coefficients c evaluated toward the front face (ω = S·e_A) and a side face
// (ω = W_D·S·e_A + W_S·T·e_B).
#define E_FRONT(c, A, S) (SH_Y0 * (c).x + (SH_SGN(A) * (S) * SH_Y1) * (c)[SH_K(A)])
#define E_SIDE(c, A, S, B, T) \
    (SH_Y0 * (c).x + (SH_SGN(A) * (S) * SH_Y1 * W_D) * (c)[SH_K(A)] + (SH_SGN(B) * (T) * SH_Y1 * W_S) * (c)[SH_K(B)])
// SH coefficients c evaluated toward face f of a direction.
#define E_F0(c, A, S, B1, B2) E_FRONT(c, A, S)
#define E_F1(c, A, S, B1, B2) E_SIDE(c, A, S, B1, 1.0)
#define E_F2(c, A, S, B1, B2) E_SIDE(c, A, S, B1, -1.0)
#define E_F3(c, A, S, B1, B2) E_SIDE(c, A, S, B2, 1.0)
#define E_F4(c, A, S, B1, B2) E_SIDE(c, A, S, B2, -1.0)
// Face f's normal, along which the neighbour re-emits: axis LOBE_A<f>, sign LOBE_N<f>.
#define LOBE_A0(A, B1, B2) A
#define LOBE_A1(A, B1, B2) B1
#define LOBE_A2(A, B1, B2) B1
#define LOBE_A3(A, B1, B2) B2
#define LOBE_A4(A, B1, B2) B2
#define LOBE_N0(S) (S)
#define LOBE_N1(S) 1.0
#define LOBE_N2(S) -1.0
#define LOBE_N3(S) 1.0
#define LOBE_N4(S) -1.0

#define FOR_EACH_DIRECTION(M) \
    M(0, 0, 1.0, 1, 2)        \
    M(1, 0, -1.0, 1, 2)       \
    M(2, 1, 1.0, 0, 2)        \
    M(3, 1, -1.0, 0, 2)       \
    M(4, 2, 1.0, 0, 1)        \
    M(5, 2, -1.0, 0, 1)
#endif

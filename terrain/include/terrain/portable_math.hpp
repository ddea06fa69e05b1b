// Transcendental functions that the CPU reference and the GLSL evaluators compute bit for bit
// alike. libm and GLSL built-ins are each accurate to an ulp or two but not equal, and a one-ulp
// angle can move a height across a tile's quantisation step; so node kernels use these instead.
// Each is plain float arithmetic in a fixed order (the terrain library is built with
// -ffp-contract=off; gpu/glsl/portable_math.glsl is the same sequence under `precise`), with
// constants given as bit patterns so that no compiler parses a decimal differently.
#pragma once

namespace terrain {

/// atan2(y, x) in [−π, π]: octant reduction to t = min/max ∈ [0, 1], then t' = (t − 1)/(t + 1)
/// above tan(π/8) (offset π/4), and Cephes' degree-9 odd minimax polynomial of atanf on
/// |t'| ≤ tan(π/8). Largest error against the exact atan2 over the plane: 2.7e-7 rad (about one
/// ulp of π; libm's atan2f reaches 2.5e-7 on the same sweep); relative error below 1e-7 near 0.
/// (0, 0) gives 0; y = −0 is treated as +0; NaN inputs give NaN or 0 (never used by kernels).
float portable_atan2(float y, float x);

}  // namespace terrain

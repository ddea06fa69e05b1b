// The program interpreter (docs/program.md): walks the instruction stream once per point with
// explicit field and frame stacks (no recursion), like terrain::Evaluator::evaluate does for a
// block of points. Needs from the prelude: fetch_code(pc) (a uvec4 Instruction), program_size(),
// TERRAIN_MAX_FIELDS and TERRAIN_MAX_FRAMES (Program::max_field_depth + 1, max_frame_depth + 1).
// Culling tests the single point against the boxes: since culling only skips children that have
// no weight at a point, results equal the CPU's block-wise culling.
//
// A shader may instead define TERRAIN_SPECIALISED and append the program's own
// evaluate_program (gpu::specialised_program_glsl: the same instruction stream unrolled into
// straight-line calls of these node functions), so that it runs no instruction fetch and no
// dispatch over node types. The prototype below lets that definition follow the tracer.

const uint kOpLeaf = 0u;
const uint kOpBlendBegin = 1u;
const uint kOpBlendAdd = 2u;
const uint kOpBlendEnd = 3u;
const uint kOpCull = 4u;
const uint kOpGroup = 5u;
const uint kOpCombine = 6u;
const uint kOpWarpBegin = 7u;
const uint kOpWarpEnd = 8u;

const uint kTypeDisc = 1u;
const uint kTypeCurve = 2u;
const uint kTypeContour = 3u;
const uint kTypeImage = 4u;
const uint kTypeReplace = 17u;
const uint kTypeAdd = 18u;
const uint kTypeLod = 19u;
const uint kTypeTransform = 32u;
const uint kTypeWarp = 33u;

bool box_contains(uint at, vec2 p) {
  return fetch_pool(at) <= p.x && p.x <= fetch_pool(at + 2u) && fetch_pool(at + 1u) <= p.y &&
         p.y <= fetch_pool(at + 3u);
}

Field evaluate_program(vec2 p, float spacing);

// A curve leaf; where the parent ignores f outside the weight's support, far points stop early.
Field curve_leaf_field(uint at, vec2 p, bool weighted_only) {
  float cutoff = weighted_only ? (fetch_pool(at + 9u) + fetch_pool(at)) * 1.001
                               : uintBitsToFloat(0x7f800000u);
  return curve_leaf(at, p, cutoff);
}

// A transform's child sample spacing.
float transform_spacing(uint at, float spacing) { return spacing * fetch_pool(at + 14u); }

#ifndef TERRAIN_SPECIALISED
// A prelude may leave out the code of node types its programs do not use by defining
// TERRAIN_USES_<TYPE> as 0 (gpu::node_type_defines): every branch costs registers on a GPU, and
// software rasterizers run each one's straight-line code at every instruction.
#ifndef TERRAIN_USES_DISC
#define TERRAIN_USES_DISC 1
#endif
#ifndef TERRAIN_USES_CURVE
#define TERRAIN_USES_CURVE 1
#endif
#ifndef TERRAIN_USES_CONTOUR
#define TERRAIN_USES_CONTOUR 1
#endif
#ifndef TERRAIN_USES_IMAGE
#define TERRAIN_USES_IMAGE 1
#endif
#ifndef TERRAIN_USES_REPLACE
#define TERRAIN_USES_REPLACE 1
#endif
#ifndef TERRAIN_USES_ADD
#define TERRAIN_USES_ADD 1
#endif
#ifndef TERRAIN_USES_LOD
#define TERRAIN_USES_LOD 1
#endif
#ifndef TERRAIN_USES_TRANSFORM
#define TERRAIN_USES_TRANSFORM 1
#endif
#ifndef TERRAIN_USES_WARP
#define TERRAIN_USES_WARP 1
#endif

Field leaf_field(uint type, uint at, bool weighted_only, vec2 p, float spacing) {
#if TERRAIN_USES_DISC
  if (type == kTypeDisc) return disc_leaf(at, p, spacing);
#endif
#if TERRAIN_USES_CURVE
  if (type == kTypeCurve) return curve_leaf_field(at, p, weighted_only);
#endif
#if TERRAIN_USES_CONTOUR
  if (type == kTypeContour) return contour_leaf(at, p);
#endif
#if TERRAIN_USES_IMAGE
  if (type == kTypeImage) return image_leaf(at, p);
#endif
  // Unsupported types are refused by the host before a program is run; NaN makes misuse loud.
  float nan = uintBitsToFloat(0x7fc00000u);
  return Field(nan, nan, nan, nan, nan, nan);
}

// f, α and gradients of the program's root at p, at level of detail `spacing`.
Field evaluate_program(vec2 p, float spacing) {
  Field fields[TERRAIN_MAX_FIELDS];
  vec2 frame_point[TERRAIN_MAX_FRAMES];
  float frame_spacing[TERRAIN_MAX_FRAMES];
  vec4 frame_jacobian[TERRAIN_MAX_FRAMES];
  int sp = 0;
  int fp = 0;
  vec2 point = p;
  float detail = spacing;
  uint size = program_size();
  for (uint pc = 0u; pc < size; ++pc) {
    uvec4 ins = fetch_code(pc);
    uint op = ins.x & 0xffffu;
    uint type = ins.x >> 16;
    uint at = ins.y;
    if (op == kOpLeaf) {
      fields[sp++] = leaf_field(type, at, ins.z != 0u, point, detail);
    } else if (op == kOpBlendBegin) {
      fields[sp++] = field_zero();
    } else if (op == kOpBlendAdd) {
      --sp;
      fields[sp - 1] = blend_accumulate(fields[sp - 1], fields[sp]);
    } else if (op == kOpBlendEnd) {
      fields[sp - 1] = blend_finish(at, fields[sp - 1]);
    } else if (op == kOpCull) {
      if (!box_contains(at, point)) {
        fields[sp++] = field_zero();
        pc += ins.z;
      }
    } else if (op == kOpGroup) {
      if (!box_contains(at, point)) pc += ins.z;
    } else if (op == kOpCombine) {
      --sp;
#if TERRAIN_USES_REPLACE
      if (type == kTypeReplace) fields[sp - 1] = replace_combine(at, fields[sp - 1], fields[sp]);
#endif
#if TERRAIN_USES_ADD
      if (type == kTypeAdd) fields[sp - 1] = add_combine(at, fields[sp - 1], fields[sp]);
#endif
#if TERRAIN_USES_LOD
      if (type == kTypeLod) fields[sp - 1] = lod_combine(at, detail, fields[sp - 1], fields[sp]);
#endif
    } else if (op == kOpWarpBegin) {
      frame_point[fp] = point;
      frame_spacing[fp] = detail;
      ++fp;
#if TERRAIN_USES_TRANSFORM
      if (type == kTypeTransform) {
        point = transform_point(at, point);
        detail = transform_spacing(at, detail);
      }
#endif
#if TERRAIN_USES_WARP
      if (type == kTypeWarp) {
        vec4 j;
        point = warp_point(at, point, detail, j);
        frame_jacobian[fp] = j;
      }
#endif
    } else if (op == kOpWarpEnd) {
#if TERRAIN_USES_TRANSFORM
      if (type == kTypeTransform) fields[sp - 1] = transform_field(at, fields[sp - 1]);
#endif
#if TERRAIN_USES_WARP
      if (type == kTypeWarp) fields[sp - 1] = warp_field(frame_jacobian[fp], fields[sp - 1]);
#endif
      --fp;
      point = frame_point[fp];
      detail = frame_spacing[fp];
    }
  }
  return fields[0];
}
#endif  // TERRAIN_SPECIALISED

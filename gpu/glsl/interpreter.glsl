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

bool box_contains(uint at, vec2 p) {
  return fetch_pool(at) <= p.x && p.x <= fetch_pool(at + 2u) && fetch_pool(at + 1u) <= p.y &&
         p.y <= fetch_pool(at + 3u);
}

Field evaluate_program(vec2 p, float spacing);

#ifndef TERRAIN_SPECIALISED
// The dispatch over node types (leaf_field, combine_fields, enter_frame, leave_frame) is
// generated from the node registry (gpu::node_dispatch_glsl) and precedes this file; a prelude
// may leave out the code of node types its programs do not use by defining TERRAIN_USES_<TYPE>
// as 0 (gpu::node_type_defines): every branch costs registers on a GPU, and software
// rasterizers run each one's straight-line code at every instruction.

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
      fields[sp - 1] = combine_fields(type, at, detail, fields[sp - 1], fields[sp]);
    } else if (op == kOpWarpBegin) {
      frame_point[fp] = point;
      frame_spacing[fp] = detail;
      ++fp;
      vec2 q;
      float t;
      enter_frame(type, at, point, detail, q, t, frame_jacobian[fp]);
      point = q;
      detail = t;
    } else if (op == kOpWarpEnd) {
      fields[sp - 1] = leave_frame(type, at, frame_jacobian[fp], fields[sp - 1]);
      --fp;
      point = frame_point[fp];
      detail = frame_spacing[fp];
    }
  }
  return fields[0];
}
#endif  // TERRAIN_SPECIALISED

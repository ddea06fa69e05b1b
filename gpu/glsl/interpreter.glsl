// The program interpreter (docs/program.md): walks the instruction stream once per point with
// explicit field and frame stacks (no recursion), like terrain::Evaluator::evaluate does for a
// block of points. Needs from the prelude: fetch_code(pc) (a uvec4 Instruction), program_size(),
// TERRAIN_MAX_FIELDS and TERRAIN_MAX_FRAMES (Program::max_field_depth + 1, max_frame_depth + 1).
// Culling tests the single point against the boxes: since culling only skips children that have
// no weight at a point, results equal the CPU's block-wise culling.

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

Field leaf_field(uint type, uint at, bool weighted_only, vec2 p, float spacing) {
  if (type == kTypeDisc) return disc_leaf(at, p, spacing);
  if (type == kTypeCurve) {
    // Where the parent ignores f outside the weight's support, far points stop early.
    float cutoff = weighted_only ? (fetch_pool(at + 9u) + fetch_pool(at)) * 1.001
                                 : uintBitsToFloat(0x7f800000u);
    return curve_leaf(at, p, cutoff);
  }
  if (type == kTypeContour) return contour_leaf(at, p);
  if (type == kTypeImage) return image_leaf(at, p);
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
      if (type == kTypeReplace) {
        fields[sp - 1] = replace_combine(at, fields[sp - 1], fields[sp]);
      } else if (type == kTypeAdd) {
        fields[sp - 1] = add_combine(at, fields[sp - 1], fields[sp]);
      } else {
        fields[sp - 1] = lod_combine(at, detail, fields[sp - 1], fields[sp]);
      }
    } else if (op == kOpWarpBegin) {
      frame_point[fp] = point;
      frame_spacing[fp] = detail;
      ++fp;
      if (type == kTypeTransform) {
        point = transform_point(at, point);
        detail = detail * fetch_pool(at + 14u);
      } else {
        vec4 j;
        point = warp_point(at, point, detail, j);
        frame_jacobian[fp] = j;
      }
    } else if (op == kOpWarpEnd) {
      if (type == kTypeTransform) {
        fields[sp - 1] = transform_field(at, fields[sp - 1]);
      } else {
        fields[sp - 1] = warp_field(frame_jacobian[fp], fields[sp - 1]);
      }
      --fp;
      point = frame_point[fp];
      detail = frame_spacing[fp];
    }
  }
  return fields[0];
}

// The editing model: which primitives a scene's canonical JSON holds, where they lie in scene
// metres, which one a point of the ground belongs to, and the JSON Patch ops (docs/live.md) that
// move one or change its radius or elevation. No DOM here: edit_mode.js is the UI.
//
// Positions go through `transform` nodes (p = T + R·S·q, as terrain/src/nodes/transform.cpp),
// nested ones composed, and through `{"ref"}` instancing: a primitive inside a definition is
// listed once per instance, each with its own placement, and an edit changes the definition
// (so every instance moves). `warp` nodes displace by noise, which is not followed here: their
// primitives are placed as if unwarped (off by at most the warp's amplitude).

// A 2D affine map p = [a b; c d]·q + [tx, ty].
const IDENTITY = Object.freeze({ a: 1, b: 0, c: 0, d: 1, tx: 0, ty: 0 });

function transformOf(node) {
  const angle = ((node.rotate ?? 0) * Math.PI) / 180;
  const [sx, sy] = Array.isArray(node.scale) ? node.scale : [node.scale ?? 1, node.scale ?? 1];
  const [tx, ty] = node.translate ?? [0, 0];
  const cos = Math.cos(angle), sin = Math.sin(angle);
  return { a: cos * sx, b: -sin * sy, c: sin * sx, d: cos * sy, tx, ty };
}

/// outer ∘ inner: first inner, then outer.
function compose(o, i) {
  return {
    a: o.a * i.a + o.b * i.c, b: o.a * i.b + o.b * i.d,
    c: o.c * i.a + o.d * i.c, d: o.c * i.b + o.d * i.d,
    tx: o.a * i.tx + o.b * i.ty + o.tx, ty: o.c * i.tx + o.d * i.ty + o.ty,
  };
}

function invert(m) {
  const det = m.a * m.d - m.b * m.c;
  const a = m.d / det, b = -m.b / det, c = -m.c / det, d = m.a / det;
  return { a, b, c, d, tx: -(a * m.tx + b * m.ty), ty: -(c * m.tx + d * m.ty) };
}

export function applyAffine(m, [x, y]) {
  return [m.a * x + m.b * y + m.tx, m.c * x + m.d * y + m.ty];
}

function applyLinear(m, [x, y]) {
  return [m.a * x + m.b * y, m.c * x + m.d * y];
}

/// A JSON pointer token (RFC 6901): "~" and "/" escaped.
export function pointerToken(key) {
  return String(key).replaceAll('~', '~0').replaceAll('/', '~1');
}

/// The names of the primitive node types in the server's registry (GET /api/v1/node-types): the
/// nodes an editor can pick and move. The list is the server's, so a new primitive needs no edit
/// here beyond what its own fields mean for picking (centre, radius, elevation below).
export function primitiveTypes(registry) {
  return new Set((registry?.node_types ?? []).filter((t) => t.category === 'primitive').map((t) => t.name));
}
const BEZIER_STEPS = 16;  // points per curved piece when a skeleton is flattened for picking

/// The points of a skeleton (pieces of 2–4 [x, y, z] points: a segment or a Bézier), flattened.
function skeletonPolyline(pieces) {
  const points = [];
  for (const piece of pieces ?? []) {
    if (!Array.isArray(piece) || piece.length < 2) continue;
    const n = piece.length - 1;
    const steps = n === 1 ? 1 : BEZIER_STEPS;
    for (let s = points.length ? 1 : 0; s <= steps; ++s) {
      // De Casteljau on x and y.
      const t = s / steps;
      let layer = piece.map((p) => [p[0], p[1]]);
      while (layer.length > 1) {
        layer = layer.slice(1).map((p, k) => [layer[k][0] + (p[0] - layer[k][0]) * t, layer[k][1] + (p[1] - layer[k][1]) * t]);
      }
      points.push(layer[0]);
    }
  }
  return points;
}

function distanceToPolyline(q, points) {
  let best = Infinity;
  for (let i = 0; i + 1 < points.length; ++i) {
    const [ax, ay] = points[i], [bx, by] = points[i + 1];
    const ex = bx - ax, ey = by - ay;
    const len2 = ex * ex + ey * ey;
    const t = len2 > 0 ? Math.max(0, Math.min(1, ((q[0] - ax) * ex + (q[1] - ay) * ey) / len2)) : 0;
    best = Math.min(best, Math.hypot(q[0] - ax - t * ex, q[1] - ay - t * ey));
  }
  if (points.length === 1) best = Math.hypot(q[0] - points[0][0], q[1] - points[0][1]);
  return best;
}

function centroid(points) {
  const n = Math.max(points.length, 1);
  return [points.reduce((s, p) => s + p[0], 0) / n, points.reduce((s, p) => s + p[1], 0) / n];
}

/// A convex quadrangle (either winding) contains q.
function insideConvex(q, corners) {
  let sign = 0;
  for (let i = 0; i < corners.length; ++i) {
    const [ax, ay] = corners[i], [bx, by] = corners[(i + 1) % corners.length];
    const cross = (bx - ax) * (q[1] - ay) - (by - ay) * (q[0] - ax);
    if (cross === 0) continue;
    if (sign === 0) sign = Math.sign(cross);
    else if (Math.sign(cross) !== sign) return false;
  }
  return true;
}

/// A contour's radius at angle θ (radians, from +x): the radii lie at equal angles from
/// `orientation`; linear between them (the server interpolates smoothly: close enough to pick).
function contourRadius(node, theta) {
  const radii = node.radii ?? [node.radius ?? 1];
  const n = radii.length;
  const start = ((node.orientation ?? 0) * Math.PI) / 180;
  let u = ((theta - start) / (2 * Math.PI)) * n;
  u = ((u % n) + n) % n;
  const i = Math.floor(u), f = u - i;
  return radii[i] * (1 - f) + radii[(i + 1) % n] * f;
}

/// Every primitive instance of a canonical scene document, in tree order (the root, then the
/// water layer): { pointer, type, node, frame (local → scene metres), tree, instance (how many
/// earlier entries share the pointer), warped, label }. `primitives`: primitiveTypes' set.
export function listPrimitives(doc, primitives) {
  const out = [];
  const seen = new Map();  // pointer -> instances so far
  const visit = (node, pointer, frame, tree, refs, warped) => {
    if (!node || typeof node !== 'object') return;
    if (typeof node.ref === 'string') {
      const definition = doc.definitions?.[node.ref];
      if (!definition || refs.includes(node.ref)) return;  // the server refuses cycles anyway
      visit(definition, `/definitions/${pointerToken(node.ref)}`, frame, tree, [...refs, node.ref], warped);
      return;
    }
    if (primitives.has(node.type)) {
      const instance = seen.get(pointer) ?? 0;
      seen.set(pointer, instance + 1);
      const name = node.id ? ` “${node.id}”` : '';
      const where = tree === 'water' ? ' (water)' : '';
      const copy = refs.length ? ` · instance ${instance + 1} of ${refs[refs.length - 1]}` : '';
      out.push({ pointer, type: node.type, node, frame, tree, instance, warped,
        label: `${node.type}${name}${where}${copy}` });
      return;
    }
    const inner = node.type === 'transform' ? compose(frame, transformOf(node)) : frame;
    (node.children ?? []).forEach((child, i) =>
      visit(child, `${pointer}/children/${i}`, inner, tree, refs, warped || node.type === 'warp'));
  };
  visit(doc.root, '/root', IDENTITY, 'root', [], false);
  if (doc.water) visit(doc.water, '/water', IDENTITY, 'water', [], false);
  return out;
}

/// A primitive's reference point in its own frame: the centre of a disc or contour, the middle
/// of an image's corners or of a skeleton's points.
function localCentre(p) {
  const n = p.node;
  if (Array.isArray(n.center)) return n.center;
  if (Array.isArray(n.corners)) return centroid(n.corners);
  const pieces = n.pieces ?? n.curve?.pieces;
  return centroid(skeletonPolyline(pieces));
}

/// The reference point in scene metres.
export function worldCentre(p) {
  return applyAffine(p.frame, localCentre(p));
}

/// The radius shown for a disc (its radius) or contour (the mean of its radii), else null.
export function radiusOf(p) {
  if (p.type === 'disc') return p.node.radius;
  if (p.type === 'contour') {
    const radii = p.node.radii ?? [p.node.radius];
    return radii.reduce((s, r) => s + r, 0) / radii.length;
  }
  return null;
}

/// The elevation field of discs, contours and images (in the primitive's own units: a
/// transform's elevation_scale applies on top), else null.
export function elevationOf(p) {
  return typeof p.node.elevation === 'number' && p.type !== 'curve' ? p.node.elevation : null;
}

/// How far inside its support a point (scene metres) is: 0 at the centre, 1 at the edge,
/// Infinity outside.
function supportScore(p, point) {
  const q = applyAffine(invert(p.frame), point);
  const n = p.node;
  let score = Infinity;
  if (p.type === 'disc') {
    score = Math.hypot(q[0] - n.center[0], q[1] - n.center[1]) / n.radius;
  } else if (p.type === 'contour') {
    const dx = q[0] - n.center[0], dy = q[1] - n.center[1];
    const rho = Math.hypot(dx, dy) / contourRadius(n, Math.atan2(dy, dx));
    score = rho / (n.falloff ?? 1.25);
  } else if (p.type === 'image' && Array.isArray(n.corners)) {
    if (insideConvex(q, n.corners)) {
      const c = centroid(n.corners);
      const reach = Math.max(...n.corners.map((k) => Math.hypot(k[0] - c[0], k[1] - c[1])));
      score = Math.hypot(q[0] - c[0], q[1] - c[1]) / reach;
    }
  } else {
    const pieces = n.pieces ?? n.curve?.pieces;
    const reach = p.type === 'curve' ? n.falloff ?? n.core ?? 50 : (n.curve?.width ?? 100) / 2;
    score = distanceToPolyline(q, skeletonPolyline(pieces)) / reach;
  }
  return score < 1 ? score : Infinity;
}

/// The index of the terrain primitive (not water) whose support contains `point` (scene
/// metres), the one the point is most central in; -1 when none.
export function pickPrimitive(primitives, point) {
  let best = -1, bestScore = Infinity;
  primitives.forEach((p, i) => {
    if (p.tree !== 'root') return;
    const score = supportScore(p, point);
    if (score < bestScore) {
      best = i;
      bestScore = score;
    }
  });
  return best;
}

// Centimetres are plenty, and keep the JSON short.
const round = (v) => Math.round(v * 100) / 100;

/// Ops that move a primitive by `delta` (scene metres): its centre, corners or skeleton shifted
/// by the delta brought into its own frame.
export function moveOps(p, delta) {
  const [dx, dy] = applyLinear(invert(p.frame), delta);
  const shift = (point) => [round(point[0] + dx), round(point[1] + dy), ...point.slice(2)];
  const n = p.node;
  if (Array.isArray(n.center)) return [{ op: 'replace', path: `${p.pointer}/center`, value: shift(n.center) }];
  if (Array.isArray(n.corners)) return [{ op: 'replace', path: `${p.pointer}/corners`, value: n.corners.map(shift) }];
  if (Array.isArray(n.pieces)) {
    return [{ op: 'replace', path: `${p.pointer}/pieces`, value: n.pieces.map((piece) => piece.map(shift)) }];
  }
  if (Array.isArray(n.curve?.pieces)) {
    return [{ op: 'replace', path: `${p.pointer}/curve/pieces`, value: n.curve.pieces.map((piece) => piece.map(shift)) }];
  }
  return [];
}

/// Ops that set the radius: a disc's `radius`; a contour's `radii` scaled so their mean is the
/// new value (its shape kept). The value is sent as typed: the server validates it.
export function radiusOps(p, radius) {
  if (p.type === 'disc') return [{ op: 'replace', path: `${p.pointer}/radius`, value: radius }];
  if (p.type === 'contour') {
    const factor = radius / radiusOf(p);
    const radii = (p.node.radii ?? [p.node.radius]).map((r) => round(r * factor));
    return [{ op: 'replace', path: `${p.pointer}/radii`, value: radii }];
  }
  return [];
}

export function elevationOps(p, elevation) {
  return elevationOf(p) === null ? [] : [{ op: 'replace', path: `${p.pointer}/elevation`, value: elevation }];
}

/// A copy of `doc` with `replace` ops applied (the only kind the editor sends), for the
/// document an acknowledged edit made without fetching it again.
export function applyReplaceOps(doc, ops) {
  const out = structuredClone(doc);
  for (const op of ops) {
    const keys = op.path.split('/').slice(1).map((k) => k.replaceAll('~1', '/').replaceAll('~0', '~'));
    const last = keys.pop();
    let parent = out;
    for (const k of keys) parent = parent[k];
    parent[last] = structuredClone(op.value);
  }
  return out;
}

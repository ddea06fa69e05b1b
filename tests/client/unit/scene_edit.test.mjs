// The browser's editing model (client_web/js/scene_edit.js): which nodes are primitives comes
// from the server's registry listing; primitives are placed through transforms and instances;
// edits become JSON-pointer replacements. Run by ctest (client_unit) with Node's test runner.
import assert from 'node:assert/strict';
import { test } from 'node:test';

import {
  applyReplaceOps, listPrimitives, moveOps, pickPrimitive, primitiveTypes, worldCentre,
} from '../../../client_web/js/scene_edit.js';

// The shape of GET /api/v1/node-types (the server's test checks it against the registry).
const REGISTRY = { node_types: [
  { name: 'disc', category: 'primitive' }, { name: 'curve', category: 'primitive' },
  { name: 'blend', category: 'blend' }, { name: 'transform', category: 'warp' },
  { name: 'warp', category: 'warp' }, { name: 'future_peak', category: 'primitive' },
] };

test('primitive types are the registry entries of category primitive', () => {
  assert.deepEqual([...primitiveTypes(REGISTRY)].sort(), ['curve', 'disc', 'future_peak']);
  assert.equal(primitiveTypes(undefined).size, 0);
});

test('a primitive type new to the registry is listed without an edit of the client', () => {
  const doc = { root: { type: 'blend', children: [{ type: 'future_peak', center: [5, 6] }, { type: 'disc', center: [0, 0], radius: 3 }] } };
  const list = listPrimitives(doc, primitiveTypes(REGISTRY));
  assert.deepEqual(list.map((p) => p.type), ['future_peak', 'disc']);
  assert.deepEqual(listPrimitives(doc, new Set(['disc'])).map((p) => p.pointer), ['/root/children/1']);
});

test('primitives are placed through transforms, per instance, and moves replace their centre', () => {
  const doc = { definitions: { hill: { type: 'disc', center: [0, 0], radius: 30 } },
    root: { type: 'blend', children: [
      { type: 'transform', translate: [100, 0], rotate: 90, scale: [2, 2], children: [{ type: 'disc', center: [10, 0], radius: 50 }] },
      { type: 'transform', translate: [-500, 0], children: [{ ref: 'hill' }] },
      { type: 'warp', noise: {}, children: [{ type: 'disc', center: [7, 7], radius: 1 }] },
    ] } };
  const list = listPrimitives(doc, primitiveTypes(REGISTRY));
  assert.deepEqual(list.map((p) => p.pointer), ['/root/children/0/children/0', '/definitions/hill', '/root/children/2/children/0']);
  const round = (v) => v.map((x) => Math.round(x * 1000) / 1000);
  assert.deepEqual(round(worldCentre(list[0])), [100, 20]);
  assert.deepEqual(round(worldCentre(list[1])), [-500, 0]);
  assert.equal(list[2].warped, true);
  assert.equal(list[0].warped, false);
  assert.equal(pickPrimitive(list, [-505, 0]), 1);
  const moved = applyReplaceOps(doc, moveOps(list[1], [10, 0]));
  assert.deepEqual(moved.definitions.hill.center, [10, 0]);
  assert.deepEqual(doc.definitions.hill.center, [0, 0], 'the document given is left as it was');
});

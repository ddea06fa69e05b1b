// Reads a PMTiles archive with the `pmtiles` npm package (an independent reader of the format,
// the one MapLibre's protocol uses) from a local file: prints the header and metadata as JSON,
// and with Z X Y OUT writes that tile's bytes (decompressed as the header says) to OUT.
//
// Usage: node read_pmtiles.mjs PACK.pmtiles [Z X Y OUT]
import { closeSync, openSync, readSync, writeFileSync } from 'node:fs';
import { PMTiles, zxyToTileId } from 'pmtiles';

const [path, z, x, y, out] = process.argv.slice(2);
if (!path) {
  console.error('usage: node read_pmtiles.mjs PACK.pmtiles [Z X Y OUT]');
  process.exit(2);
}

// A pmtiles Source over a local file.
const fd = openSync(path, 'r');
const source = {
  getKey: () => path,
  getBytes: async (offset, length) => {
    const buffer = Buffer.alloc(length);
    const n = readSync(fd, buffer, 0, length, offset);
    return { data: buffer.buffer.slice(buffer.byteOffset, buffer.byteOffset + n) };
  },
};
const archive = new PMTiles(source);
const header = await archive.getHeader();
const metadata = await archive.getMetadata();
const report = { header, metadata };
if (out) {
  const tile = await archive.getZxy(Number(z), Number(x), Number(y));
  if (!tile) {
    console.error(`no tile ${z}/${x}/${y} in ${path}`);
    process.exit(1);
  }
  writeFileSync(out, Buffer.from(tile.data));
  report.tile = { z: Number(z), x: Number(x), y: Number(y), id: zxyToTileId(Number(z), Number(x), Number(y)),
    bytes: tile.data.byteLength };
}
closeSync(fd);
console.log(JSON.stringify(report));

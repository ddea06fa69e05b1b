// Frame times of the browser viewer's sphere tracer (client_web/js/scene_view.js) in Debian's
// headless Chromium: for every example scene and shader mode (gpu::ShaderMode, chosen with the
// page's ?glsl=), the time from opening the page to its first full-resolution view (fetches,
// shader compilation, previews and bands) and the median of full-resolution frames traced again
// at the same camera (the GPU work included: the tracer waits for a pixel of the result).
//
// Usage: node bench/browser_frames.mjs SERVER_BINARY [--size 64x40] [--frames 3]
//          [--modes automatic,pruned,unrolled,interpreter] [--scenes butte,craters] [--browser-arg ARG]...
// Without --browser-arg, WebGL2 runs on SwiftShader (the CPU); on a machine with a GPU pass the
// flags that put Chromium on it, e.g. --browser-arg=--use-angle=vulkan
// --browser-arg=--enable-features=Vulkan --browser-arg=--ignore-gpu-blocklist. The WebGL
// renderer is printed, so the figures name the device they were measured on.
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';
import { launchBrowser, openViewer, startServer, waitIdle } from '../tests/client/browser_harness.mjs';

const argv = process.argv.slice(2);
const option = (name, fallback) => {
  const i = argv.indexOf(name);
  return i >= 0 ? argv[i + 1] : fallback;
};
const serverBinary = argv[0];
if (!serverBinary || serverBinary.startsWith('--')) {
  console.error('usage: node bench/browser_frames.mjs SERVER_BINARY [--size WxH] [--frames N] ' +
    '[--modes M,...] [--scenes S,...] [--browser-arg ARG]...');
  process.exit(2);
}
const [width, height] = option('--size', '64x40').split('x').map(Number);
const frames = Number(option('--frames', '3'));
const modes = option('--modes', 'automatic').split(',');
const browserArgs = argv.flatMap((a, i) => (a === '--browser-arg' ? [argv[i + 1]] :
  a.startsWith('--browser-arg=') ? [a.slice('--browser-arg='.length)] : []));

const repoRoot = join(dirname(fileURLToPath(import.meta.url)), '..');
const { port, stop } = await startServer(serverBinary, repoRoot);
const base = `http://127.0.0.1:${port}`;
const browser = await launchBrowser(browserArgs.length ? browserArgs : undefined);
let failed = false;
try {
  const listed = (await (await fetch(`${base}/api/v1/scenes`)).json()).scenes.map((s) => s.id);
  const scenes = option('--scenes', listed.join(',')).split(',');
  console.log(`${width}×${height} pixels, median of ${frames} frames`);
  console.log('| Scene | Mode | Open to first full view | Full frame |');
  console.log('|---|---|---|---|');
  let renderer = '';
  for (const scene of scenes) {
    for (const mode of modes) {
      const { page, start } = await openViewer(browser, `${base}/?glsl=${mode}#scene=${scene}`, width, height);
      const error = await waitIdle(page, 600000);
      const opened = Date.now() - start;
      if (error) {
        console.log(`| ${scene} | ${mode} | failed: ${error} | |`);
        failed = true;
        await page.close();
        continue;
      }
      const result = await page.evaluate(([w, h, n]) => {
        const { view, camera, gl } = window.terrainViewer.state;
        const times = [];
        for (let i = 0; i < n; ++i) {
          view.targets.full.complete = null;  // trace again rather than read the finished view
          times.push(view.capture(camera, w, h).ms);
        }
        times.sort((a, b) => a - b);
        const info = gl.getExtension('WEBGL_debug_renderer_info');
        return {
          median: times[Math.floor(n / 2)],
          renderer: info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER),
        };
      }, [width, height, frames]);
      renderer = result.renderer;
      console.log(`| ${scene} | ${mode} | ${(opened / 1000).toFixed(1)} s | ${result.median.toFixed(0)} ms |`);
      await page.close();
    }
  }
  console.log(`\nWebGL renderer: ${renderer}`);
} finally {
  await browser.close();
  stop();
}
process.exit(failed ? 1 : 0);

// The report's 3D view in headless chromium (software WebGL, as the browser tests): page size,
// load to first frame, and the frame time while orbiting (issue 31). Prints JSON.
//
//   node bench/bench_report_viewer.mjs [REPORT.html] [--runs 3] [--frames 60]
//                                      [--screenshot docs/scan-report.jpg]
//
// Default report: build/demo/scan/report.html (`build/fringe demo --out build/demo`). Needs
// web/viewer/node_modules (npm ci there) and /usr/bin/chromium. Run it under benchlock.
import { statSync, writeFileSync } from 'node:fs';
import { dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { createRequire } from 'node:module';

const root = join(dirname(fileURLToPath(import.meta.url)), '..');
const require = createRequire(join(root, 'web', 'viewer', 'package.json'));
const { chromium } = require('playwright-core');

const args = process.argv.slice(2);
const option = (name, fallback) => {
  const i = args.indexOf(name);
  return i >= 0 ? args.splice(i, 2)[1] : fallback;
};
const runs = Number(option('--runs', 3));
const frames = Number(option('--frames', 60));
const screenshot = option('--screenshot', null);
const report = resolve(args[0] || join(root, 'build', 'demo', 'scan', 'report.html'));
const url = `file://${report}`;

const result = { report, page_bytes: statSync(report).size, runs: [] };
for (let run = 0; run < runs; ++run) {
  const browser = await chromium.launch({ executablePath: '/usr/bin/chromium',
                                          args: ['--use-angle=swiftshader'] });
  const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
  await page.goto(url);
  await page.waitForFunction(() => window.fringeViewer && window.fringeViewer.firstFrameMs !== null,
                             null, { timeout: 60000 });
  const r = await page.evaluate(async (n) => {
    const v = window.fringeViewer;
    const nav = performance.getEntriesByType('navigation')[0];
    const d = v.description;
    const orbit = await v.benchOrbit(n);
    return {
      first_frame_ms: v.firstFrameMs,   // from the navigation's start
      html_parsed_ms: nav.domInteractive,
      viewer_start_ms: v.timings.start_ms,
      scene_read_ms: v.timings.read_ms,
      viewer_build_ms: v.timings.build_ms,
      triangles: d.mesh?.triangles, full_triangles: d.mesh?.full_triangles,
      points: d.points?.count,
      orbit_frame_ms: orbit.frame_ms, orbit_fps: orbit.fps, renderer: v.renderer.getContext()
        .getParameter(v.renderer.getContext().getExtension('WEBGL_debug_renderer_info')
          .UNMASKED_RENDERER_WEBGL),
    };
  }, frames);
  result.runs.push(r);
  if (screenshot && run === runs - 1) {
    await page.evaluate(() => {
      const v = window.fringeViewer;
      v.reset();
      v.orbit(0.35, 0.08);
    });
    await page.evaluate(() => document.querySelector('.fringe-scene').scrollIntoView({ block: 'start' }));
    const box = await page.locator('.fringe-scene canvas').boundingBox();
    await page.mouse.click(box.x + box.width * 0.5, box.y + box.height * 0.45);
    await page.waitForTimeout(500);
    await page.locator('.fringe-scene').screenshot({ path: screenshot, type: 'jpeg', quality: 85 });
    result.screenshot = screenshot;
  }
  await browser.close();
}
const median = (k) => {
  const v = result.runs.map((r) => r[k]).sort((a, b) => a - b);
  return v[Math.floor(v.length / 2)];
};
result.median = { first_frame_ms: median('first_frame_ms'), orbit_frame_ms: median('orbit_frame_ms'),
                  orbit_fps: median('orbit_fps') };
console.log(JSON.stringify(result, null, 2));

// The report's 3D view in a real browser: Debian's chromium, headless, driven by playwright-core
// (no browser download), software WebGL (SwiftShader). One case per run, as ctest registers them
// (web/viewer/CMakeLists.txt):
//
//   node browser_test.mjs CASE REPORT_DIR
//
// REPORT_DIR holds a scan's output (report.html, mesh.ply), made by make_report.sh from a small
// simulated scan; for the case `calibration`, a calibration report folder (report.html,
// summary.json) made by make_calibration_report.sh. Exit 0 passed, 1 failed, 77 skipped (node_modules or chromium absent, unless
// FRINGE_REQUIRE_SHARED_DATA=1, where that fails).
import { existsSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import { inflateSync } from 'node:zlib';

const [testCase, dir] = process.argv.slice(2);
const chromiumPath = process.env.FRINGE_CHROMIUM || '/usr/bin/chromium';

function skip(why) {
  if (process.env.FRINGE_REQUIRE_SHARED_DATA === '1') {
    console.error(`FAIL: ${why}; FRINGE_REQUIRE_SHARED_DATA=1 needs it`);
    process.exit(1);
  }
  console.log(`SKIP: ${why}`);
  process.exit(77);
}

let chromium;
try {
  ({ chromium } = await import('playwright-core'));
} catch (e) {
  skip(`web/viewer/node_modules is absent (npm ci in web/viewer, or scripts/install-deps.sh)`);
}
if (!existsSync(chromiumPath)) skip(`${chromiumPath} is absent (apt-get install chromium)`);

const failures = [];
function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures.push(what);
}

// The scene of the page, decoded here without the viewer: description and arrays.
function sceneOf(html) {
  const description = JSON.parse(
      html.match(/<script type="application\/json" id="fringe-scene-0-description">(.*?)<\/script>/s)[1]);
  const [, stated, b64] = html.match(
      /<script type="application\/octet-stream" data-encoding="deflate" data-bytes="(\d+)" id="fringe-scene-0-arrays">(.*?)<\/script>/s);
  const bytes = inflateSync(Buffer.from(b64, 'base64'));
  if (bytes.length !== Number(stated)) throw new Error(`the scene inflates to ${bytes.length} bytes, not ${stated}`);
  const types = { float32: Float32Array, uint32: Uint32Array, uint16: Uint16Array, uint8: Uint8Array };
  const arrays = {};
  for (const [name, a] of Object.entries(description.arrays)) {
    const copy = new Uint8Array(bytes.subarray(a.offset, a.offset + a.count * types[a.type].BYTES_PER_ELEMENT));
    arrays[name] = new types[a.type](copy.buffer);
  }
  return { description, arrays };
}

// The vertices of a binary little-endian PLY with float x y z first (fringe's mesh.ply).
function plyVertices(path) {
  const data = readFileSync(path);
  const end = data.indexOf('end_header\n') + 'end_header\n'.length;
  const header = data.subarray(0, end).toString('latin1');
  const count = Number(header.match(/element vertex (\d+)/)[1]);
  const props = header.split('element vertex')[1].split('element')[0].match(/property (\w+) /g);
  if (!header.includes('binary_little_endian') || !props.every((p) => p === 'property float ')) {
    throw new Error(`${path}: not fringe's float vertex layout`);
  }
  const stride = props.length * 4;
  const out = new Float64Array(3 * count);
  for (let i = 0; i < count; ++i) {
    for (let k = 0; k < 3; ++k) out[3 * i + k] = data.readFloatLE(end + i * stride + 4 * k);
  }
  return out;
}

const reportPath = join(dir, 'report.html');
if (!existsSync(reportPath)) {
  console.error(`FAIL: ${reportPath} is missing (the fixture web/SmallScanReport writes it)`);
  process.exit(1);
}
const url = `file://${reportPath}`;
const webgl = testCase !== 'no-webgl';
const browser = await chromium.launch({
  executablePath: chromiumPath,
  // Software WebGL: ANGLE on SwiftShader (the fastest software path of headless chromium).
  args: webgl ? ['--use-angle=swiftshader'] : ['--disable-webgl', '--disable-3d-apis'],
});
const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
const consoleErrors = [];
const requests = [];
page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
page.on('pageerror', (e) => consoleErrors.push(e.message));
page.on('request', (r) => { if (r.url() !== url && !r.url().startsWith('data:')) requests.push(r.url()); });
// Nothing may leave the page: anything but the page itself is refused (and counted above).
await page.route((u) => u.href !== url && !u.href.startsWith('data:'), (route) => route.abort());

try {
  await page.goto(url);
  await page.waitForFunction(
      () => window.fringeViewers !== undefined &&
            (window.fringeViewer === null || window.fringeViewer.firstFrameMs !== null),
      null, { timeout: 15000 });

  // The 3D view in the viewport (the mouse acts on what is on screen).
  const canvas = page.locator('.fringe-scene canvas').first();
  if (webgl) {
    await page.evaluate(() => document.querySelector('.fringe-scene')?.scrollIntoView({ block: 'start' }));
  }
  const canvasShot = async () => {
    await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    return (await canvas.screenshot({ type: 'png' })).toString('base64');
  };
  // Figures of screenshots, computed in the page (it decodes PNG; node has no decoder):
  // `covered`, the fraction of the first's pixels that differ from the background (the colour
  // near its corner), and `changed`, the fraction of pixels that differ between the two (any channel by
  // more than 12 of 255).
  const compare = async (a, b = a) => page.evaluate(async ([pa, pb]) => {
    const decode = async (b64) => {
      const img = new Image();
      img.src = `data:image/png;base64,${b64}`;
      await img.decode();
      const c = document.createElement('canvas');
      c.width = img.width;
      c.height = img.height;
      const ctx = c.getContext('2d');
      ctx.drawImage(img, 0, 0);
      return ctx.getImageData(0, 0, c.width, c.height);
    };
    const image = await decode(pa), x = image.data, y = (await decode(pb)).data;
    const bg = (5 * image.width + 5) * 4;  // inside the canvas' edge
    let covered = 0, changed = 0;
    for (let i = 0; i < x.length; i += 4) {
      if (Math.abs(x[i] - x[bg]) + Math.abs(x[i + 1] - x[bg + 1]) + Math.abs(x[i + 2] - x[bg + 2]) > 30) ++covered;
      if (Math.abs(x[i] - y[i]) > 12 || Math.abs(x[i + 1] - y[i + 1]) > 12 ||
          Math.abs(x[i + 2] - y[i + 2]) > 12) ++changed;
    }
    return { covered: covered / (x.length / 4), changed: changed / (x.length / 4) };
  }, [a, b]);

  if (testCase === 'offline') {
    // Loads with no console error and no request beyond the file itself.
    const state = await page.evaluate(() => ({
      viewer: !!window.fringeViewer, frames: window.fringeViewer?.frames,
      first: window.fringeViewer?.firstFrameMs, canvas: !!document.querySelector('.fringe-scene canvas'),
    }));
    check(state.viewer && state.canvas, 'the 3D view starts (a WebGL canvas in the page)');
    check(state.frames >= 1, `it drew (${state.frames} frames, first at ${Math.round(state.first)} ms)`);
    check(consoleErrors.length === 0, `no console error (${consoleErrors.join(' | ') || 'none'})`);
    check(requests.length === 0, `no network request (${requests.join(', ') || 'none'})`);
    const html = readFileSync(reportPath, 'latin1');
    check(!/(src|href)="(https?:)?\/\//.test(html), 'no external src or href in the page');
  } else if (testCase === 'render') {
    // The canvas shows the model; turning it (a real drag) changes the picture.
    const box = await canvas.boundingBox();
    const before = await canvasShot();
    const cover = (await compare(before)).covered;
    check(cover > 0.05 && cover < 0.9,
          `the model covers a plausible part of the view (${(100 * cover).toFixed(1)} %)`);
    await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
    await page.mouse.down();
    await page.mouse.move(box.x + box.width / 2 + 200, box.y + box.height / 2 + 40, { steps: 8 });
    await page.mouse.up();
    const after = await canvasShot();
    const c = (await compare(before, after)).changed;
    check(c > 0.03, `orbiting (a drag) changes the picture (${(100 * c).toFixed(1)} % of pixels)`);
    await page.click('.fringe-scene .fv-reset');
    const reset = await canvasShot();
    check((await compare(before, reset)).changed < 0.01, 'reset view gives the first picture back');
    check(consoleErrors.length === 0, `no console error (${consoleErrors.join(' | ') || 'none'})`);
  } else if (testCase === 'picker') {
    // A click on the model picks a mesh vertex; its coordinates are those of that vertex in
    // mesh.ply (the small scan's mesh is not decimated: same vertices, same order).
    const html = readFileSync(reportPath, 'latin1');
    const { description, arrays } = sceneOf(html);
    check(description.mesh.triangles === description.mesh.full_triangles,
          `the page holds the whole mesh (${description.mesh.triangles} triangles)`);
    const ply = plyVertices(join(dir, 'mesh.ply'));
    const box = await canvas.boundingBox();
    const at = { x: box.x + box.width / 2, y: box.y + box.height / 2 };
    await page.mouse.click(at.x, at.y);
    const pick = await page.evaluate(() => window.fringeViewer.lastPick);
    check(pick && pick.kind === 'mesh vertex', `the click picked a mesh vertex (${pick?.index})`);
    const i = pick.index;
    const known = [ply[3 * i], ply[3 * i + 1], ply[3 * i + 2]];
    const err = Math.max(...known.map((v, k) => Math.abs(v - pick.world[k])));
    check(err < 0.01, `picked coordinates within 0.01 mm of mesh.ply's vertex ${i} (${err.toExponential(2)} mm)`);
    const embedded = [0, 1, 2].map((k) => arrays[description.mesh.positions][3 * i + k] + description.origin[k]);
    check(Math.max(...embedded.map((v, k) => Math.abs(v - pick.world[k]))) < 1e-6,
          'and those of the page\'s data');
    const screen = await page.evaluate((w) => window.fringeViewer.project(w), known);
    const px = Math.hypot(screen.x - at.x, screen.y - at.y);
    check(px < 8, `that vertex is where the click was (${px.toFixed(2)} px away)`);
    const dev = arrays['mesh.deviation'][i];
    check(pick.deviation !== undefined && Math.abs((pick.deviation ?? NaN) - dev) < 1e-6,
          `the pick gives the vertex's deviation (${pick.deviation} mm)`);
    check(description.views.map((v) => v.name).includes(pick.view), `and its view (${pick.view})`);
    const info = await page.locator('.fringe-scene .fv-info').textContent();
    check(info.includes(pick.world[0].toFixed(3)) && info.includes('signed deviation'),
          `the page shows it: "${info.split('\n')[0]}"`);
    check(consoleErrors.length === 0, `no console error (${consoleErrors.join(' | ') || 'none'})`);
  } else if (testCase === 'colours') {
    // Colouring by height, then by deviation: the colours change. Selecting a view in a table
    // highlights it (the other views' parts fade).
    await page.selectOption('.fringe-scene select.fv-colouring', 'height');
    const height = await canvasShot();
    await page.selectOption('.fringe-scene select.fv-colouring', 'deviation');
    const deviation = await canvasShot();
    const cmp = await compare(deviation, height);
    const c = cmp.changed / cmp.covered;
    check(c > 0.3, `colouring by deviation changes the model's colours (${(100 * c).toFixed(0)} % of its pixels)`);
    const legend = await page.locator('.fringe-scene .fv-legend canvas').count();
    check(legend === 1, 'a colour bar in mm is shown');
    const row = page.locator('tr.fringe-view-row').first();
    const name = (await row.locator('td').first().textContent()).trim();
    await row.click();
    const highlighted = await page.evaluate(() => window.fringeViewer.highlighted);
    check(highlighted === name, `a click on the tables' row of view ${name} highlights it (${highlighted})`);
    const lit = await canvasShot();
    const h = (await compare(deviation, lit)).changed;
    check(h > 0.02, `and the 3D view shows it (${(100 * h).toFixed(1)} % of pixels changed)`);
    check(consoleErrors.length === 0, `no console error (${consoleErrors.join(' | ') || 'none'})`);
  } else if (testCase === 'calibration') {
    // The calibration report (REPORT_DIR holds report.html and summary.json of `fringe
    // calibrate --report`): the boards at the used poses, coloured by each pose's residual, and
    // the devices at their calibrated poses.
    const html = readFileSync(reportPath, 'latin1');
    const summary = JSON.parse(readFileSync(join(dir, 'summary.json'), 'utf8')).diagnostics;
    const { description, arrays } = sceneOf(html);
    const used = summary.poses.filter((p) => p.used);
    check(description.boards.length === summary.used_poses && used.length === summary.used_poses,
          `a board per used pose (${description.boards.length} of ${summary.used_poses})`);
    // Each board's colour value is its pose's RMS over every device's features.
    const rms = description.colourings.find((k) => k.id === 'pose_rms');
    let worst = 0;
    used.forEach((p, i) => {
      let ss = 0, n = 0;
      for (const d of Object.values(p.devices)) { ss += d.features * d.rms_px ** 2; n += d.features; }
      worst = Math.max(worst, Math.abs(Math.sqrt(ss / n) - rms.boards[i]));
      if (description.boards[i].name !== p.name) worst = Infinity;
    });
    check(worst < 1e-9, `each board carries its pose's RMS residual from summary.json (${worst.toExponential(2)} px off)`);
    const names = description.views.map((v) => v.name);
    check(summary.devices.every((d) => names.includes(d.name)),
          `every device has a frustum (${names.join(', ')})`);
    // The second camera sits at the calibrated baseline from the first.
    const second = description.views[1];
    const t = second.world_from_sensor;
    const baseline = summary.distances_mm.baseline ?? summary.distances_mm['projector distance'];
    const off = Math.abs(Math.hypot(t[3], t[7], t[11]) - baseline);
    check(off < 1e-6, `${second.name} at the calibrated distance ${baseline.toFixed(3)} mm (${off.toExponential(2)} mm off)`);
    check(arrays['points.positions'].length === 3 * description.points.count,
          `the boards' features (${description.points.count})`);
    const state = await page.evaluate(() => ({
      viewer: !!window.fringeViewer, frames: window.fringeViewer?.frames,
      boards: Object.keys(window.fringeViewer?.boards || {}).length,
    }));
    check(state.viewer && state.frames >= 1 && state.boards === description.boards.length,
          `the 3D view draws them (${state.boards} boards, ${state.frames} frames)`);
    const before = await canvasShot();
    const cover = (await compare(before)).covered;
    check(cover > 0.02 && cover < 0.9, `the boards cover a plausible part of the view (${(100 * cover).toFixed(1)} %)`);
    await page.evaluate(() => window.fringeViewer.orbit(0.6, 0.2));
    const turned = await canvasShot();
    check((await compare(before, turned)).changed > 0.02, 'orbiting changes the picture');
    await page.click('.fringe-scene .fv-reset');
    // The picker returns a board feature: the nearest one to the camera, clicked where it shows.
    const p = arrays['points.positions'];
    let target = null;
    for (let i = 0; i < description.points.count; i += 7) {
      const w = [0, 1, 2].map((k) => p[3 * i + k] + description.origin[k]);
      const s = await page.evaluate((x) => window.fringeViewer.project(x), w);
      if (!target || s.depth < target.s.depth) target = { i, w, s };
    }
    await page.mouse.click(target.s.x, target.s.y);
    const pick = await page.evaluate(() => window.fringeViewer.lastPick);
    check(pick && pick.kind === 'point', `a click on a board feature picks it (${pick?.index})`);
    if (pick) {
      const q = [0, 1, 2].map((k) => p[3 * pick.index + k] + description.origin[k]);
      const err = Math.max(...q.map((v, k) => Math.abs(v - pick.world[k])));
      const s = await page.evaluate((x) => window.fringeViewer.project(x), q);
      check(err < 0.01 && Math.hypot(s.x - target.s.x, s.y - target.s.y) < 8,
            `at that feature's coordinates (${err.toExponential(2)} mm) where the click was`);
      check(pick.pose_rms !== undefined && Math.abs(pick.pose_rms - arrays['points.pose_rms'][pick.index]) < 1e-6,
            `with its pose's residual (${pick.pose_rms} px) and pose (${pick.pose})`);
    }
    // A click on a pose's row in the tables highlights its board.
    const row = page.locator('tr.fringe-view-row', { hasText: description.boards[0].name }).first();
    const plain = await canvasShot();
    await row.click();
    await page.evaluate(() => document.querySelector('.fringe-scene').scrollIntoView({ block: 'start' }));
    const lit = await page.evaluate(() => window.fringeViewer.highlightedBoard);
    check(lit === description.boards[0].name, `a click on pose ${description.boards[0].name}'s row highlights its board (${lit})`);
    check((await compare(plain, await canvasShot())).changed > 0.005, 'and the 3D view shows it');
    check(consoleErrors.length === 0, `no console error (${consoleErrors.join(' | ') || 'none'})`);
    check(requests.length === 0, `no network request (${requests.join(', ') || 'none'})`);
  } else if (testCase === 'no-webgl') {
    // Without WebGL: the pictures are there and the page says why the 3D view is not.
    const state = await page.evaluate(() => ({
      message: document.querySelector('.fringe-scene .fv-no-webgl')?.textContent || '',
      canvas: document.querySelectorAll('.fringe-scene canvas').length,
      images: Array.from(document.images).filter((i) => i.complete && i.naturalWidth > 0).length,
      all: document.images.length,
    }));
    check(state.message.includes('WebGL'), `the page says why: "${state.message.slice(0, 90)}..."`);
    check(state.canvas === 0, 'no 3D canvas');
    check(state.images >= 5 && state.images === state.all, `its ${state.images} pictures show`);
    check(requests.length === 0, `no network request (${requests.join(', ') || 'none'})`);
  } else {
    check(false, `unknown case ${testCase}`);
  }
} catch (e) {
  check(false, `${e.message}`);
} finally {
  await browser.close();
}
console.log(failures.length ? `${failures.length} check(s) failed` : 'all checks passed');
process.exit(failures.length ? 1 : 0);

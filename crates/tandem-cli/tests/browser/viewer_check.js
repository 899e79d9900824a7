// Opens a tandem viewer.html in headless Chromium and checks it (driven by ../viewer.rs).
//
//   node viewer_check.js VIEWER_HTML OUT_DIR [CHROMIUM]
//
// Fails (exit 1, reason on stderr) on: any request that is not the file itself or a data: URL,
// any console error or page error, tandemViewer.ready not set within 20 s. Otherwise seeks to
// t = 0 and t = T/2, writes OUT_DIR/shot_t0.png and OUT_DIR/shot_mid.png, and prints one JSON
// line with what the Rust test checks: the arms' screen box at both times, the HUD and legend
// boxes, the share of pixels that differ inside the arms' box outside the HUD and legend, and
// the share of non-background pixels of the 3-D view.
'use strict';
const fs = require('fs');
const path = require('path');
const zlib = require('zlib');
const { pathToFileURL } = require('url');
const { chromium } = require('playwright-core');

const [html, outDir, exe = '/usr/bin/chromium'] = process.argv.slice(2);
if (!html || !outDir) {
  console.error('usage: node viewer_check.js VIEWER_HTML OUT_DIR [CHROMIUM]');
  process.exit(2);
}

// Minimal PNG decoder (8-bit RGB/RGBA, non-interlaced: what Chromium writes) → RGBA pixels.
function decodePng(buf) {
  let off = 8, w = 0, h = 0, ct = 0;
  const idat = [];
  while (off < buf.length) {
    const len = buf.readUInt32BE(off), type = buf.toString('ascii', off + 4, off + 8);
    const data = buf.subarray(off + 8, off + 8 + len);
    if (type === 'IHDR') {
      w = data.readUInt32BE(0); h = data.readUInt32BE(4); ct = data[9];
      if (data[8] !== 8 || data[12] !== 0 || (ct !== 2 && ct !== 6)) throw new Error('unsupported PNG');
    } else if (type === 'IDAT') idat.push(data);
    off += 12 + len;
  }
  const bpp = ct === 6 ? 4 : 3, stride = w * bpp, raw = zlib.inflateSync(Buffer.concat(idat));
  const out = Buffer.alloc(w * h * 4), prev = Buffer.alloc(stride), line = Buffer.alloc(stride);
  for (let y = 0; y < h; y++) {
    const f = raw[y * (stride + 1)], src = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let i = 0; i < stride; i++) {
      const a = i >= bpp ? line[i - bpp] : 0, b = prev[i], c = i >= bpp ? prev[i - bpp] : 0;
      let v = src[i];
      if (f === 1) v += a;
      else if (f === 2) v += b;
      else if (f === 3) v += (a + b) >> 1;
      else if (f === 4) {
        const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
        v += pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      }
      line[i] = v & 255;
    }
    for (let x = 0; x < w; x++) {
      out[(y * w + x) * 4] = line[x * bpp];
      out[(y * w + x) * 4 + 1] = line[x * bpp + 1];
      out[(y * w + x) * 4 + 2] = line[x * bpp + 2];
      out[(y * w + x) * 4 + 3] = bpp === 4 ? line[x * bpp + 3] : 255;
    }
    line.copy(prev);
  }
  return { w, h, px: out };
}

function inside(r, x, y) { return r && x >= r.x && x < r.x + r.width && y >= r.y && y < r.y + r.height; }

(async () => {
  const fileUrl = pathToFileURL(path.resolve(html)).href;
  const problems = [];
  const requests = [];
  const browser = await chromium.launch({
    executablePath: exe,
    headless: true,
    args: [
      '--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
      '--disable-component-update', '--disable-sync', '--no-first-run',
      '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
    ],
  });
  try {
    const context = await browser.newContext({ viewport: { width: 1200, height: 800 }, deviceScaleFactor: 1 });
    context.on('request', (r) => {
      const u = r.url();
      requests.push(u);
      if (u !== fileUrl && !u.startsWith('data:')) problems.push('network request: ' + u);
    });
    const page = await context.newPage();
    page.on('console', (m) => { if (m.type() === 'error') problems.push('console error: ' + m.text()); });
    page.on('pageerror', (e) => problems.push('page error: ' + e.message));
    page.on('requestfailed', (r) => problems.push('request failed: ' + r.url()));
    await page.goto(fileUrl, { waitUntil: 'load' });
    await page.waitForFunction(() => window.tandemViewer && window.tandemViewer.ready === true, null, { timeout: 20000 });
    const info = await page.evaluate(() => ({ frames: window.tandemViewer.frames, duration: window.tandemViewer.duration }));
    const shot = async (t, name) => {
      const state = await page.evaluate((t) => {
        window.tandemViewer.pause();
        const cur = window.tandemViewer.seek(t);
        return new Promise((res) => requestAnimationFrame(() => requestAnimationFrame(() => {
          const rect = (id) => { const r = document.getElementById(id).getBoundingClientRect(); return { x: r.x, y: r.y, width: r.width, height: r.height }; };
          res({ t: cur, hudText: document.getElementById('hud').innerText, arms: window.tandemViewer.armScreenBox(), hud: rect('hud'), legend: rect('legend'), bar: rect('bar') });
        })));
      }, t);
      const file = path.join(outDir, name);
      await page.screenshot({ path: file });
      return { ...state, png: decodePng(fs.readFileSync(file)), file };
    };
    const a = await shot(0, 'shot_t0.png');
    const b = await shot(info.duration / 2, 'shot_mid.png');

    // Pixels that differ (any channel by more than 24) inside the union of the arms' boxes,
    // outside the HUD, the legend and the control bar.
    const overlays = [a.hud, a.legend, a.bar, b.hud, b.legend, b.bar];
    const box = a.arms && b.arms ? {
      x0: Math.max(0, Math.floor(Math.min(a.arms.x0, b.arms.x0))), y0: Math.max(0, Math.floor(Math.min(a.arms.y0, b.arms.y0))),
      x1: Math.min(a.png.w, Math.ceil(Math.max(a.arms.x1, b.arms.x1))), y1: Math.min(a.png.h, Math.ceil(Math.max(a.arms.y1, b.arms.y1))),
    } : null;
    let inBox = 0, diffInBox = 0, diffHud = 0, nonBg = 0, visible = 0;
    const bg = [a.png.px[0], a.png.px[1], a.png.px[2]];
    for (let y = 0; y < a.png.h; y++) {
      for (let x = 0; x < a.png.w; x++) {
        const i = (y * a.png.w + x) * 4;
        const d = Math.max(Math.abs(a.png.px[i] - b.png.px[i]), Math.abs(a.png.px[i + 1] - b.png.px[i + 1]), Math.abs(a.png.px[i + 2] - b.png.px[i + 2]));
        const over = overlays.some((r) => inside(r, x, y));
        if (over) { if (d > 24) diffHud++; continue; }
        visible++;
        const dBg = Math.max(Math.abs(a.png.px[i] - bg[0]), Math.abs(a.png.px[i + 1] - bg[1]), Math.abs(a.png.px[i + 2] - bg[2]));
        if (dBg > 24) nonBg++;
        if (box && x >= box.x0 && x < box.x1 && y >= box.y0 && y < box.y1) {
          inBox++;
          if (d > 24) diffInBox++;
        }
      }
    }
    // Controls: the space bar plays and pauses, 4× speed advances time, the view buttons and
    // a left drag (orbit), a wheel turn (zoom) and a right drag (pan) change the picture.
    const sample = () => page.evaluate(() => {
      const c = document.getElementById('gl'), g = c.getContext('webgl');
      const px = new Uint8Array(4 * 64 * 64);
      g.readPixels(c.width / 2 - 32, c.height / 2 - 32, 64, 64, g.RGBA, g.UNSIGNED_BYTE, px);
      let h = 0;
      for (let i = 0; i < px.length; i++) h = (h * 31 + px[i]) >>> 0;
      return h;
    });
    const controls = {};
    if (info.frames > 1) {
      await page.evaluate(() => window.tandemViewer.seek(0));
      await page.selectOption('#speed', '4');
      await page.mouse.click(600, 400); // focus the page (a click without a drag)
      await page.keyboard.press(' ');
      await page.waitForTimeout(500);
      await page.keyboard.press(' ');
      const t1 = await page.evaluate(() => window.tandemViewer.time());
      await page.waitForTimeout(200);
      const t2 = await page.evaluate(() => window.tandemViewer.time());
      controls.space_played_s = t1;
      controls.space_paused = t1 === t2;
    }
    const changes = async (act) => {
      const before = await sample();
      await act();
      await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
      return (await sample()) !== before;
    };
    controls.top_button = await changes(() => page.click('button[data-view=top]'));
    controls.reset_button = await changes(() => page.click('#reset'));
    controls.orbit = await changes(async () => {
      await page.mouse.move(600, 420); await page.mouse.down();
      await page.mouse.move(700, 380, { steps: 5 }); await page.mouse.up();
    });
    controls.zoom = await changes(async () => { await page.mouse.move(600, 420); await page.mouse.wheel(0, 400); });
    controls.pan = await changes(async () => {
      await page.mouse.move(600, 420); await page.mouse.down({ button: 'right' });
      await page.mouse.move(520, 470, { steps: 5 }); await page.mouse.up({ button: 'right' });
    });

    const report = {
      controls,
      frames: info.frames, duration: info.duration, t: [a.t, b.t], arms: [a.arms, b.arms], box,
      hud: a.hud, hud_text: [a.hudText, b.hudText], requests, problems,
      arm_box_pixels: inBox, arm_box_diff_share: inBox ? diffInBox / inBox : 0, hud_diff_pixels: diffHud,
      non_background_share: visible ? nonBg / visible : 0, shots: [a.file, b.file],
    };
    console.log(JSON.stringify(report));
    if (problems.length) {
      console.error(problems.join('\n'));
      process.exitCode = 1;
    }
  } finally {
    await browser.close();
  }
})().catch((e) => { console.error('viewer_check: ' + (e && e.stack || e)); process.exit(1); });

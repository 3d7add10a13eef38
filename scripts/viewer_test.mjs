// Headless browser test of the web viewer (run by scripts/viewer_test.sh): Debian's chromium
// through playwright-core (installed by the script, never a dependency of derma) opens
// `derma view`, loads the exported GLB with three.js' GLTFLoader, checks the shader-evaluated
// rig against derma's CPU evaluation (`derma rig eval`), moves the "happiness" (smile) slider
// and checks that the cheeks flush while the forehead stays and that the crow's feet deepen in
// the normal map only inside the regions the smile drives, checks the live eye model against
// derma's evaluator and that the upper lid follows the gaze in the picture, the model in the
// vertex shader against the JavaScript port and the lacrimal lake in the picture, then saves a
// screenshot (EYESHOT=PREFIX also saves crops of the eyes at several gazes).
// Usage: node viewer_test.mjs PLAYWRIGHT_DIR URL NEUTRAL.png HAPPY.png SCREENSHOT.png
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';

const [pwDir, url, neutralRef, happyRef, shot] = process.argv.slice(2);
const require = createRequire(path.join(pwDir, 'package.json'));
const { chromium } = require('playwright-core');

let failures = 0;
const fail = (msg) => {
  console.error(`viewer test: ${msg}`);
  failures += 1;
};

// CIELAB (D65) of 8-bit sRGB (IEC 61966-2-1; CIE 15:2004).
function lab([r, g, b]) {
  const lin = (c) => ((c /= 255) <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4);
  const [R, G, B] = [r, g, b].map(lin);
  const X = (0.4124 * R + 0.3576 * G + 0.1805 * B) / 0.95047;
  const Y = 0.2126 * R + 0.7152 * G + 0.0722 * B;
  const Z = (0.0193 * R + 0.1192 * G + 0.9505 * B) / 1.08883;
  const f = (t) => (t > 216 / 24389 ? Math.cbrt(t) : (24389 / 27 * t + 16) / 116);
  return [116 * f(Y) - 16, 500 * (f(X) - f(Y)), 200 * (f(Y) - f(Z))];
}
const deltaE = (a, b) => Math.hypot(...lab(a).map((x, i) => x - lab(b)[i]));
const hue = (c) => (Math.atan2(lab(c)[2], lab(c)[1]) * 180) / Math.PI;

// Largest per-channel difference between the viewer's albedo and a reference PNG, in the page.
async function compare(page, refFile) {
  const ref = fs.readFileSync(refFile).toString('base64');
  return page.evaluate(async (b64) => {
    const a = await window.testDecode(window.derma.albedo());
    const b = await window.testDecode(`data:image/png;base64,${b64}`);
    if (a.length !== b.length) return { error: `sizes differ: ${a.length / 4} vs ${b.length / 4} texels` };
    let max = 0, sum = 0, n = 0;
    for (let i = 0; i < a.length; i += 4) {
      for (let k = 0; k < 3; k++) {
        const d = Math.abs(a[i + k] - b[i + k]);
        max = Math.max(max, d);
        sum += d;
        n += 1;
      }
    }
    return { max, mean: sum / n };
  }, ref);
}

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM ?? '/usr/bin/chromium',
  args: ['--enable-unsafe-swiftshader', '--use-angle=swiftshader', '--ignore-gpu-blocklist', '--no-sandbox'],
});
try {
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  const consoleErrors = [];
  page.on('console', (m) => m.type() === 'error' && consoleErrors.push(m.text()));
  page.on('pageerror', (e) => consoleErrors.push(String(e)));
  // 8-bit RGBA of an image URL, decoded in the page (no colour conversion, no premultiplying).
  await page.addInitScript(() => {
    window.testDecode = async (src) => {
      const img = await createImageBitmap(await (await fetch(src)).blob(), { colorSpaceConversion: 'none', premultiplyAlpha: 'none' });
      const c = new OffscreenCanvas(img.width, img.height);
      const ctx = c.getContext('2d');
      ctx.drawImage(img, 0, 0);
      return ctx.getImageData(0, 0, img.width, img.height).data;
    };
  });
  await page.goto(url);
  await page.waitForFunction(() => window.derma && (window.derma.ready || window.derma.errors.length), null, {
    timeout: 180_000,
  });
  const state = await page.evaluate(() => ({
    ready: window.derma.ready,
    errors: window.derma.errors,
    targets: window.derma.targets,
    regions: window.derma.regions,
  }));
  if (!state.ready) throw new Error(`viewer did not load: ${state.errors.join('; ')}`);
  console.log(`GLB and rig loaded: ${state.targets.length} rig targets (${state.targets.join(', ')})`);
  if (!state.targets.includes('happiness')) throw new Error('no happiness target in the rig');

  // 1. The shader evaluates the rig as derma-rig does on the CPU (8-bit sRGB; 16-bit inputs).
  const n = await compare(page, neutralRef);
  console.log(`neutral albedo vs derma rig eval: max ${n.max}, mean ${n.mean?.toFixed(4)} levels`);
  if (n.error || !(n.max <= 2 && n.mean < 0.05)) fail(`neutral albedo differs from the CPU's: ${JSON.stringify(n)}`);

  // 2. The smile, moved as a user would. The built-in happiness target raises perfusion over
  // the cheekbones (Jimenez et al. 2010 §3.1, obs. 2): search the cheek region for its peak.
  const normalRest = await page.evaluate(() => window.derma.wrinkleNormal());
  if (!normalRest) fail('the export carries no expression wrinkles');
  const [cu, cv] = state.regions.cheeks;
  const grid = [];
  for (let i = -6; i <= 6; i++) for (let j = -6; j <= 6; j++) grid.push([cu + 0.008 * i, cv + 0.008 * j]);
  const hb = (pts) => page.evaluate((p) => p.map(([u, v]) => window.derma.hemoglobinAt(u, v)), pts);
  const color = (p) => page.evaluate(([u, v]) => window.derma.colorAt(u, v), p);
  const h0 = await hb(grid);
  const f0 = (await hb([state.regions.forehead]))[0];
  const foreheadBefore = await color(state.regions.forehead);
  await page.locator('#w-happiness').fill('1');
  const h1 = await hb(grid);
  const f1 = (await hb([state.regions.forehead]))[0];
  let best = 0;
  grid.forEach((_, i) => {
    if (h1[i] ** 3 / h0[i] ** 3 > h1[best] ** 3 / h0[best] ** 3) best = i;
  });
  const gain = (h1[best] / h0[best]) ** 3;
  console.log(`cheek: hemoglobin ×${gain.toFixed(3)} at uv (${grid[best].map((x) => x.toFixed(3))}); forehead ×${((f1 / f0) ** 3).toFixed(4)}`);
  if (!(gain > 1.2)) fail(`the smile did not raise cheek hemoglobin (×${gain.toFixed(3)})`);
  if (!(Math.abs((f1 / f0) ** 3 - 1) < 0.01)) fail(`the smile changed forehead hemoglobin (×${((f1 / f0) ** 3).toFixed(4)})`);
  // Its colour: more blood darkens the cheek and turns its hue toward red (CIELAB h_ab falls).
  await page.locator('#w-happiness').fill('0');
  const cheekN = await color(grid[best]);
  await page.locator('#w-happiness').fill('1');
  const cheekH = await color(grid[best]);
  const foreheadAfter = await color(state.regions.forehead);
  const dE = deltaE(cheekN, cheekH);
  const dh = hue(cheekH) - hue(cheekN);
  const dEf = deltaE(foreheadBefore, foreheadAfter);
  console.log(`cheek colour ${cheekN.map((x) => x.toFixed(1))} → ${cheekH.map((x) => x.toFixed(1))}: ΔE*ab ${dE.toFixed(2)}, hue ${dh.toFixed(2)}°; forehead ΔE*ab ${dEf.toFixed(2)}`);
  if (!(dE >= 1 && dh < 0)) fail(`the cheek did not flush (ΔE*ab ${dE.toFixed(2)}, hue change ${dh.toFixed(2)}°)`);
  if (!(dEf < 0.5)) fail(`the forehead's colour changed with the smile (ΔE*ab ${dEf.toFixed(2)})`);
  const h = await compare(page, happyRef);
  console.log(`smile albedo vs derma rig eval: max ${h.max}, mean ${h.mean?.toFixed(4)} levels`);
  if (h.error || !(h.max <= 2 && h.mean < 0.05)) fail(`smile albedo differs from the CPU's: ${JSON.stringify(h)}`);
  const units = await page.evaluate(() => window.derma.units());
  if (!((units.mouthSmileLeft ?? 0) > 0.9)) fail(`the smile did not pose the face (mouthSmileLeft ${units.mouthSmileLeft})`);

  // The smile's expression wrinkles: the blended normal map changes in the crow's feet, and
  // nowhere outside the regions the smile drives (crow's feet, under-eye, nasolabial).
  if (normalRest) {
    const wr = await page.evaluate(async (rest) => {
      const a = await window.testDecode(rest);
      const b = await window.testDecode(window.derma.wrinkleNormal());
      // RGB images of three regions each: [forehead L, R, glabella L], [glabella R, crow's feet
      // L, R], [under-eye L, R, nasolabial L], [nasolabial R].
      const m = await Promise.all([0, 1, 2, 3].map((k) => window.testDecode(`data/wrinkles/masks_${k}.png`)));
      if (m[1].length !== a.length) return { error: 'masks and normal map differ in size' };
      let crows = 0, outside = 0, changed = 0;
      for (let i = 0; i < a.length; i += 4) {
        const d = Math.max(...[0, 1, 2].map((k) => Math.abs(a[i + k] - b[i + k])));
        if (d <= 1) continue;
        changed += 1;
        if (Math.max(m[1][i + 1], m[1][i + 2]) > 128) crows += 1;
        if (Math.max(m[1][i + 1], m[1][i + 2], m[2][i], m[2][i + 1], m[2][i + 2], m[3][i]) === 0) outside += 1;
      }
      return { changed, crows, outside };
    }, normalRest);
    console.log(`smile wrinkles: ${wr.changed} normal texels changed, ${wr.crows} in the crow's feet, ${wr.outside} outside the driven regions`);
    if (wr.error || !(wr.crows >= 10 && wr.outside === 0)) fail(`the smile's wrinkles: ${JSON.stringify(wr)}`);
  }

  // 2b. The hair cards blend (the GLB's BLEND): transparent, no alpha test, no dither.
  const hair = await page.evaluate(() => window.derma.hairMaterials());
  console.log(`hair cards: ${hair.map((h) => `${h.name} transparent ${h.transparent}, alphaTest ${h.alphaTest}`).join('; ')}`);
  if (!(hair.length >= 3 && hair.every((h) => h.transparent && h.alphaTest === 0))) fail(`hair cards that do not blend: ${JSON.stringify(hair)}`);

  // 2b'. The globes refract through the cornea and carry the tear film's gloss, as derma render.
  const eyeShading = await page.evaluate(() => window.derma.eyeShading());
  console.log(`globes: ${JSON.stringify(eyeShading)}`);
  if (!(eyeShading.length === 2 && eyeShading.every((e) => e.cornea && Math.abs(e.ior - 1.376) < 1e-6 && e.roughness <= 0.1))) fail('the globes lack the cornea');

  // 2c. The pupil slider drives the globes' morphs.
  const nextFrame = async () => page.waitForFunction((f) => window.derma.frames > f + 1, await page.evaluate(() => window.derma.frames), { timeout: 60_000 });
  await page.locator('#pupil').fill('8');
  await nextFrame();
  const wide = await page.evaluate(() => window.derma.pupil());
  await page.locator('#pupil').fill('2');
  await nextFrame();
  const narrow = await page.evaluate(() => window.derma.pupil());
  await page.locator('#pupil').fill('4');
  console.log(`pupil 8 mm: ${JSON.stringify(wide)}; 2 mm: ${JSON.stringify(narrow)}`);
  if (!(wide.eye_left?.pupilDilate === 1 && narrow.eye_right?.pupilConstrict === 1 && wide.eye_left?.pupilConstrict === 0)) fail(`the pupil slider did not drive the globes' morphs`);

  // 2e. Screen-space subsurface scattering softens the skin's light: the mean |Laplacian| of the
  // red channel (red light scatters farthest in skin, millimetres) over the middle of the face
  // falls with it on; and the frame's time either way.
  await page.evaluate(() => window.derma.frameFace());
  const detail = async (on) => {
    await page.evaluate((v) => window.derma.setSss(v), on);
    await page.waitForFunction((f) => window.derma.frames > f + 1, await page.evaluate(() => window.derma.frames), { timeout: 60_000 });
    const box = await page.locator('#view').boundingBox();
    const [w, h] = [Math.round(box.width * 0.3), Math.round(box.height * 0.3)];
    const png = await page.screenshot({ clip: { x: box.x + (box.width - w) / 2, y: box.y + (box.height - h) / 2, width: w, height: h } });
    return page.evaluate(async ([b64, w, h]) => {
      const d = await window.testDecode(`data:image/png;base64,${b64}`);
      const l = (x, y) => d[4 * (y * w + x)];
      let s = 0, n = 0;
      for (let y = 1; y < h - 1; y++) for (let x = 1; x < w - 1; x++) { s += Math.abs(4 * l(x, y) - l(x - 1, y) - l(x + 1, y) - l(x, y - 1) - l(x, y + 1)); n++; }
      return s / n;
    }, [png.toString('base64'), w, h]);
  };
  const [withSss, without] = [await detail(true), await detail(false)];
  const [msSss, msPlain] = [await page.evaluate(() => window.derma.setSss(true) && window.derma.frameMs(10)), await page.evaluate(() => !window.derma.setSss(false) && window.derma.frameMs(10))];
  await page.evaluate(() => window.derma.setSss(true));
  console.log(`subsurface scattering: mean |Laplacian| of red over the face ${without.toFixed(3)} → ${withSss.toFixed(3)}; frame ${msPlain.toFixed(1)} ms without, ${msSss.toFixed(1)} ms with (software-rendered Chromium)`);
  if (!(withSss < 0.9 * without)) fail(`the subsurface scattering did not soften the skin (${without} → ${withSss})`);

  // 2d. The idle eyes: derma-eyes' blinks as the viewer plays them, over at least 200 blinks,
  // their mean interval within 15 % of the table's at the export's activity (rest: 17 /min).
  const idle = await page.evaluate(() => window.derma.idleBlinks());
  console.log(`idle eyes: ${idle?.blinks} blinks, mean interval ${idle?.meanInterval.toFixed(2)} s against the table's ${idle?.table.toFixed(2)} s (${idle?.activity})`);
  if (!(idle && idle.blinks >= 200 && Math.abs(idle.meanInterval / idle.table - 1) <= 0.15)) fail(`the idle blinks miss table 3.1: ${JSON.stringify(idle)}`);
  await page.locator('#idle').check();
  const g0 = await page.evaluate(() => window.derma.units());
  // The first saccade or blink comes within seconds (fixations last 1.6 s on average at the
  // viewer, blinks 3.5 s apart); the frames are slow in software, so it is waited for.
  const moved = await page
    .waitForFunction((g0) => {
      const g1 = window.derma.units();
      return Object.keys(g1).some((k) => Math.abs((g1[k] ?? 0) - (g0[k] ?? 0)) > 1e-3);
    }, g0, { timeout: 20_000, polling: 250 })
    .then(() => true, () => false);
  await page.locator('#idle').uncheck();
  if (!moved) fail('the idle eyes did not move the face units in 20 s');

  // 3. The trained eye model live: the JS port against derma's evaluator at the export's check
  // poses, then the upper lid followed in the picture as the gaze drops: in a column of pixels
  // through a margin vertex, the lid's edge is the strongest rise in luminance going down from
  // the lid onto the eye, searched from just above the vertex's projection to 30 px below it.
  const check = await page.evaluate(() => window.derma.eyeCheck());
  console.log(`eye model: the viewer's port within ${check?.toFixed(5)} mm of derma's evaluator`);
  if (!(check !== null && check < 0.01)) fail(`the viewer's eye model differs from derma's by ${check} mm`);
  const ms = await page.evaluate(() => [0.25, 0.5, 1].map((s) => window.derma.eyeFrameMs(20, s)));
  console.log(`eye model in JavaScript: ${ms.map((x) => x.toFixed(2)).join(' / ')} ms a frame over ¼ / ½ / all of the region's vertices`);
  await page.locator('#w-happiness').fill('0');
  await page.evaluate(() => window.derma.lookAtEyes(0.09));
  const along = [0.2, 0.35, 0.5];
  const lidEdges = async (pitch) => {
    await page.locator('#gaze-pitch').fill(String(pitch));
    const at = await page.evaluate((ts) => ts.map((t) => window.derma.upperLidPixel(0, t)), along);
    await page.waitForFunction((f) => window.derma.frames > f + 1, await page.evaluate(() => window.derma.frames), { timeout: 60_000 });
    const out = [];
    for (const [x, y] of at) {
      const top = Math.round(y) - 10;
      const col = await page.screenshot({ clip: { x: Math.round(x), y: top, width: 1, height: 44 } });
      const row = await page.evaluate(async (b64) => {
        const d = await window.testDecode(`data:image/png;base64,${b64}`);
        const lum = [];
        for (let i = 0; i < d.length; i += 4) lum.push(0.2126 * d[i] + 0.7152 * d[i + 1] + 0.0722 * d[i + 2]);
        let best = -Infinity, at = 0;
        for (let r = 2; r < lum.length - 2; r++) {
          const rise = lum[r + 1] + lum[r + 2] - lum[r - 1] - lum[r - 2];
          if (rise > best) [best, at] = [rise, r];
        }
        return at;
      }, col.toString('base64'));
      out.push({ vertex: y, edge: top + row });
    }
    return out;
  };
  // The lid's edge is found in the picture without the subsurface scattering: the scattered
  // light softens the shading along the lid margin, where the strongest rise is read.
  await page.evaluate(() => window.derma.setSss(false));
  const ahead = await lidEdges(0);
  const down = await lidEdges(-25);
  await page.evaluate(() => window.derma.setSss(true));
  along.forEach((t, i) => {
    const dv = down[i].vertex - ahead[i].vertex;
    const de = down[i].edge - ahead[i].edge;
    console.log(`upper lid at ${t} of its margin, gaze 0 → −25°: vertex ${dv.toFixed(1)} px lower, the lid's edge in the picture ${de} px lower`);
    if (!(dv > 3)) fail(`the eye model did not lower the upper lid in downgaze (${dv.toFixed(1)} px at ${t})`);
    if (!(de >= 0.5 * dv && de <= 2 * dv + 4)) fail(`the upper lid's edge in the picture did not follow its vertex at ${t} (${de} px for ${dv.toFixed(1)})`);
  });
  // 3b. The eye model in the skin's vertex shader against the JavaScript port, in the picture:
  // the eyes' close-up at a lowered gaze with the lids half closed and surprise's raised brows
  // (face units outside the region add their offsets on top of the model), drawn both ways
  // (within a few levels: float32 on the GPU against JavaScript's doubles), and with the model
  // off (the face units alone), which must differ where the lids are.
  await page.locator('#gaze-pitch').fill('-15');
  await page.locator('#aperture').fill('-0.3');
  await page.locator('#w-surprise').fill('1');
  const eyeShot = async (setup) => {
    await page.evaluate(setup);
    await page.waitForFunction((f) => window.derma.frames > f + 1, await page.evaluate(() => window.derma.frames), { timeout: 60_000 });
    const box = await page.locator('#view').boundingBox();
    return (await page.screenshot({ clip: { x: box.x, y: box.y + box.height / 2 - 120, width: box.width, height: 240 }, timeout: 60_000 })).toString('base64');
  };
  const differ = (a, b) =>
    page.evaluate(async ([a, b]) => {
      const [x, y] = [await window.testDecode(`data:image/png;base64,${a}`), await window.testDecode(`data:image/png;base64,${b}`)];
      let over = 0, sum = 0, dark = 0;
      for (let i = 0; i < x.length; i += 4) {
        const d = [0, 1, 2].map((k) => y[i + k] - x[i + k]);
        const m = Math.max(...d.map(Math.abs));
        if (m > 8) {
          over++;
          sum += (d[0] + d[1] + d[2]) / 3;
          if (d[0] + d[1] + d[2] < 0) dark++;
        }
      }
      const n = x.length / 4;
      return { share: over / n, meanChange: over ? sum / over : 0, darker: over ? dark / over : 0 };
    }, [a, b]);
  const onGpu = await eyeShot(() => window.derma.eyesOnGpu(true) && window.derma.setLake(false));
  const inJs = await eyeShot(() => !window.derma.eyesOnGpu(false));
  await page.locator('#eye-model').uncheck();
  const unitsOnly = await eyeShot(() => true);
  await page.locator('#eye-model').check();
  const [gpuJs, gpuUnits] = [await differ(onGpu, inJs), await differ(onGpu, unitsOnly)];
  console.log(`eye model in the vertex shader against JavaScript: ${(100 * gpuJs.share).toFixed(3)} % of the close-up's pixels differ by more than 8 levels; against the face units alone ${(100 * gpuUnits.share).toFixed(2)} %`);
  if (!(gpuJs.share < 0.002)) fail(`the vertex shader's eye model differs from the JavaScript port in the picture: ${JSON.stringify(gpuJs)}`);
  if (!(gpuUnits.share > 0.005)) fail(`the vertex shader's eye model draws what the face units alone draw: ${JSON.stringify(gpuUnits)}`);

  // 3c. The lacrimal lake: with it, a thin band of the globes along the lid margins darkens (the
  // fluid's absorption, lake.rs); nothing else changes. At this framing (≈ 14 px/mm) the four
  // margins' bands of reach Λ = 1 mm, ≤ 35 mm long each, cover at most ≈ 9 % of the crop.
  const withLake = await eyeShot(() => window.derma.eyesOnGpu(true) && window.derma.setLake(true));
  const lake = await differ(onGpu, withLake);
  console.log(`lacrimal lake: ${(100 * lake.share).toFixed(2)} % of the close-up's pixels change, ${(100 * lake.darker).toFixed(0)} % of them darker, by ${lake.meanChange.toFixed(1)} levels on average`);
  if (!(lake.share > 0.001 && lake.share < 0.09 && lake.darker > 0.8)) fail(`the lacrimal lake is not a darker band along the margins: ${JSON.stringify(lake)}`);
  await page.locator('#gaze-pitch').fill('0');
  await page.locator('#aperture').fill('0');
  await page.locator('#w-surprise').fill('0');

  // 3d. What a frame costs: the JavaScript that poses the region either way, and whole frames
  // (SSS and lake on) at the default framing either way.
  await page.evaluate(() => window.derma.frameFace());
  const [applyGpu, applyJs] = await page.evaluate(() => [window.derma.eyeApplyMs(20, true), window.derma.eyeApplyMs(20, false)]);
  const [frameGpu, frameJs] = await page.evaluate(() => [window.derma.eyesOnGpu(true) && window.derma.frameMs(10), !window.derma.eyesOnGpu(false) && window.derma.frameMs(10)]);
  await page.evaluate(() => window.derma.eyesOnGpu(true));
  console.log(`eye region posed in JavaScript: ${applyGpu.toFixed(2)} ms a frame with the model in the vertex shader, ${applyJs.toFixed(2)} ms with it in JavaScript; whole frame ${frameGpu.toFixed(0)} ms against ${frameJs.toFixed(0)} ms (software-rendered Chromium: its vertex shaders run on the CPU too)`);
  await page.evaluate(() => window.derma.lookAtEyes(0.09));

  if (process.env.EYESHOT) {
    // The eye model in the viewer (README figure): both eyes at four gazes and a half blink.
    await page.evaluate(() => window.derma.lookAtEyes(0.1));
    for (const [name, yaw, pitch, ap] of [['up', 0, 20, 0], ['ahead', 0, 0, 0], ['down', 0, -25, 0], ['left', 25, 0, 0], ['half', 0, 0, -0.5]]) {
      await page.locator('#gaze-yaw').fill(String(yaw));
      await page.locator('#gaze-pitch').fill(String(pitch));
      await page.locator('#aperture').fill(String(ap));
      await page.waitForFunction((f) => window.derma.frames > f + 1, await page.evaluate(() => window.derma.frames), { timeout: 60_000 });
      const box = await page.locator('#view').boundingBox();
      await page.screenshot({ path: `${process.env.EYESHOT}-${name}.png`, clip: { x: box.x, y: box.y + box.height / 2 - 130, width: box.width, height: 260 } });
    }
    await page.locator('#aperture').fill('0');
  }
  await page.evaluate(() => window.derma.frameFace());
  await page.locator('#gaze-pitch').fill('0');
  await page.locator('#w-happiness').fill('1');

  // 4. Gaze and blink drive the face units.
  await page.locator('#gaze-yaw').fill('20');
  const look = await page.evaluate(() => window.derma.units());
  if (!(look.eyeLookOutLeft > 0.5 && look.eyeLookInRight > 0.5)) fail(`gaze did not move the lids: ${JSON.stringify(look)}`);
  await page.locator('#aperture').fill('-1');
  const shut = await page.evaluate(() => window.derma.units());
  if (!(shut.eyeBlinkLeft === 1 && shut.eyeBlinkRight === 1)) fail(`aperture −1 did not close the lids`);
  await page.locator('#aperture').fill('0');
  await page.locator('#gaze-yaw').fill('8');
  await page.waitForFunction((f) => window.derma.frames > f + 1, await page.evaluate(() => window.derma.frames), { timeout: 60_000 });
  const errors = consoleErrors.concat(await page.evaluate(() => window.derma.errors));
  if (errors.length) fail(`errors in the page: ${errors.join('\n')}`);
  await page.screenshot({ path: shot });
  console.log(`screenshot → ${shot}`);
} finally {
  await browser.close();
}
process.exit(failures ? 1 : 0);

// The browser viewer end to end: the real caustica-server with --http-listen, a scene uploaded
// with the caustica CLI, and Debian's chromium driven by playwright-core.
//   node viewer_browser_test.mjs frames   frames arrive; dragging the scene's own light changes
//                                        the lights epoch and the picture; the drag-to-frame
//                                        latency is measured; in an area-lit scene the viewer
//                                        light is added and switching the area light off darkens
//                                        the picture; under a sky, the environment's intensity
//                                        slider brightens it; the page's drag bench
//                                        (?bench=drag) logs its line
//   node viewer_browser_test.mjs tokens   with --tokens: no token shows the refusal; a token
//                                        lists only its tenant's scenes
// Exits 77 (skipped) when chromium or node_modules are missing. CAUSTICA_SERVER_BIN,
// CAUSTICA_CLIENT_BIN and CAUSTICA_SCENES_DIR name the inputs; CAUSTICA_VIEWER_SCREENSHOT=PATH
// also saves a screenshot of the page after the drag.
import { execFile, spawn } from 'node:child_process';
import { existsSync, mkdtempSync, readFileSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { promisify } from 'node:util';

const SKIP = 77;
const chromiumPath = process.env.CHROMIUM || '/usr/bin/chromium';
const serverBin = process.env.CAUSTICA_SERVER_BIN;
const clientBin = process.env.CAUSTICA_CLIENT_BIN;
const scenesDir = process.env.CAUSTICA_SCENES_DIR;
const mode = process.argv[2] || 'frames';
// Small enough for a shared CPU: the picture refines to this many passes.
const WIDTH = 192, HEIGHT = 144, PHOTONS = 20000, PASSES = 6;

function fail(message) {
  console.error(`FAIL: ${message}`);
  process.exitCode = 1;
  throw new Error(message);
}
const check = (condition, message) => { if (!condition) fail(message); };

let chromium;
try {
  ({ chromium } = await import('playwright-core'));
} catch {
  console.log('SKIP: node_modules/playwright-core is missing (npm ci --prefix tests/viewer)');
  process.exit(SKIP);
}
if (!existsSync(chromiumPath)) {
  console.log(`SKIP: ${chromiumPath} is missing (apt-get install chromium)`);
  process.exit(SKIP);
}
for (const [name, value] of Object.entries({ CAUSTICA_SERVER_BIN: serverBin, CAUSTICA_CLIENT_BIN: clientBin, CAUSTICA_SCENES_DIR: scenesDir })) {
  if (!value) { console.error(`${name} is not set`); process.exit(2); }
}

const dir = mkdtempSync(path.join(tmpdir(), 'caustica-viewer-test-'));
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

async function waitForFile(file, server, seconds = 30) {
  for (let waited = 0; waited < seconds * 1000; waited += 50) {
    if (existsSync(file)) return Number(readFileSync(file, 'utf8').trim());
    if (server.exitCode !== null) break;
    await sleep(50);
  }
  fail(`caustica-server did not write ${file}; its log:\n${server.log}`);
}

async function startServer(extraArgs = []) {
  const portFile = path.join(dir, `port-${Date.now()}`);
  const httpPortFile = `${portFile}-http`;
  const server = spawn(serverBin, ['--listen', '127.0.0.1:0', '--port-file', portFile,
    '--http-listen', '127.0.0.1:0', '--http-port-file', httpPortFile, '--device', 'cpu',
    ...extraArgs], { stdio: ['ignore', 'ignore', 'pipe'] });
  server.log = '';
  server.stderr.on('data', (chunk) => { server.log += chunk; });
  const grpcPort = await waitForFile(portFile, server);
  const httpPort = await waitForFile(httpPortFile, server);
  return { process: server, grpcPort, httpPort, url: `http://127.0.0.1:${httpPort}/` };
}

async function stopServer(server) {
  if (server.process.exitCode !== null) return server.process.exitCode;
  const exited = new Promise((resolve) => server.process.once('exit', (code, signal) => resolve(code ?? signal)));
  server.process.kill('SIGTERM');
  return exited;
}

// A bundled scene at a test-sized resolution and photon count: by default the ring scene (a
// point light over a gold ring); the Cornell box is lit by its area light only.
function smallScene(sceneName = 'ring', width = WIDTH, height = HEIGHT) {
  const scene = JSON.parse(readFileSync(path.join(scenesDir, sceneName, 'scene.json'), 'utf8'));
  scene.camera.width = width;
  scene.camera.height = height;
  scene.settings.photons = PHOTONS;
  const file = path.join(dir, `${sceneName}-small.json`);
  writeFileSync(file, JSON.stringify(scene));
  return file;
}

async function upload(server, name, token, sceneFile = smallScene()) {
  const args = ['--server', `127.0.0.1:${server.grpcPort}`, ...(token ? ['--token', token] : []),
    '--json', 'scene', 'upload', sceneFile, '--name', name];
  const { stdout } = await promisify(execFile)(clientBin, args, { env: { ...process.env, CAUSTICA_DATA_DIR: '' } });
  return JSON.parse(stdout).scene_id;
}

async function cliOutput(server, args) {
  try {
    const { stdout, stderr } = await promisify(execFile)(clientBin, ['--server', `127.0.0.1:${server.grpcPort}`, ...args],
      { env: { ...process.env, CAUSTICA_DATA_DIR: '', CAUSTICA_TOKEN: '' } });
    return stdout + stderr;
  } catch (error) {
    return `${error.stdout}${error.stderr}`;
  }
}

async function launch() {
  // Headless in a container: no sandbox (no user namespaces for it here) and no GPU.
  const browser = await chromium.launch({
    executablePath: chromiumPath,
    headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--disable-dev-shm-usage'],
  });
  const page = await browser.newPage({ viewport: { width: 900, height: 620 } });
  page.pageErrors = [];
  page.on('pageerror', (error) => page.pageErrors.push(String(error)));
  return { browser, page };
}

// Mean of the canvas's RGB channels per pixel, for comparing pictures.
const canvasPixels = (page) => page.evaluate(() => {
  const canvas = document.getElementById('frame');
  const data = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
  const grey = new Array(data.length / 4);
  for (let i = 0; i < grey.length; ++i) grey[i] = (data[4 * i] + data[4 * i + 1] + data[4 * i + 2]) / 3;
  return grey;
});
const meanDifference = (a, b) => a.reduce((sum, value, i) => sum + Math.abs(value - b[i]), 0) / a.length;
const mean = (a) => a.reduce((sum, value) => sum + value, 0) / a.length;

// Drags light `index`'s handle to image position (u, v) in five moves, as a hand would.
async function dragHandle(page, index, u, v) {
  const handle = await page.locator(`#handles .handle[data-index="${index}"]`).boundingBox();
  check(handle, `light ${index} has no handle`);
  const box = await page.locator('#frame').boundingBox();
  const x0 = handle.x + handle.width / 2, y0 = handle.y + handle.height / 2;
  const x1 = box.x + u * box.width, y1 = box.y + v * box.height;
  await page.mouse.move(x0, y0);
  await page.mouse.down();
  for (let step = 1; step <= 5; ++step) {
    await page.mouse.move(x0 + (x1 - x0) * step / 5, y0 + (y1 - y0) * step / 5);
    await sleep(30);
  }
  await page.mouse.up();
}

// Waits until the picture shows a lights epoch after `epoch` and has refined to its target.
async function waitForLightsAfter(page, epoch) {
  await page.waitForFunction((e) => {
    const v = window.causticaViewer;
    return v.lastFrame.epochs.lights > e && v.idle;
  }, epoch, { timeout: 120000 });
  // The last change may still be on its way after the first one showed.
  await sleep(500);
  await page.waitForFunction(() => window.causticaViewer.idle, null, { timeout: 120000 });
}

async function framesTest() {
  const server = await startServer();
  const { browser, page } = await launch();
  try {
    const sceneId = await upload(server, 'ring-small');
    await page.goto(`${server.url}?scene=${sceneId}&passes=${PASSES}`);
    await page.waitForFunction(() => window.causticaViewer.framesDrawn >= 1, null, { timeout: 60000 });
    await page.waitForFunction(() => window.causticaViewer.idle, null, { timeout: 120000 });
    const before = await page.evaluate(() => window.causticaViewer);
    check(before.errors.length === 0, `errors before the drag: ${JSON.stringify(before.errors)}`);
    check(before.lastFrame.passes === PASSES, `the picture stopped at ${before.lastFrame.passes} passes`);
    check(before.lastFrame.width === WIDTH && before.lastFrame.height === HEIGHT, 'frame size');
    // Frames come as JPEG strips by default, decoded each on its own and drawn one under another.
    const stripRows = before.lastFrame.strip_rows || [];
    check(stripRows.length === 4 && stripRows.reduce((sum, rows) => sum + rows, 0) === HEIGHT &&
      (before.lastFrame.strip_bytes || []).length === 4, `strips: ${JSON.stringify(stripRows)}`);
    check(await page.evaluate(() => document.getElementById('frame').height) === HEIGHT, 'canvas height');
    const overlay = await page.textContent('#overlay');
    check(/pass \d+\/\d+/.test(overlay) && /lights \d+/.test(overlay) && /render [\d.]+/.test(overlay),
      `overlay: ${overlay}`);
    const pixelsBefore = await canvasPixels(page);

    // A second socket of the same origin: mistakes get errors that name them, and the socket
    // (and the server) carry on.
    const replies = await page.evaluate(() => new Promise((resolve, reject) => {
      const socket = new WebSocket(`ws://${location.host}/ws`);
      const texts = [];
      socket.onmessage = (event) => {
        if (typeof event.data !== 'string') return;
        texts.push(JSON.parse(event.data));
        if (texts.length === 3) { socket.close(); resolve(texts); }
      };
      socket.onopen = () => {
        socket.send('{nope');
        socket.send('{"type":"hello","colour":"red"}');
        socket.send('{"type":"hello"}');
      };
      setTimeout(() => reject(new Error(`replies so far: ${JSON.stringify(texts)}`)), 20000);
    }));
    check(replies[0].type === 'error' && replies[0].message.includes('not JSON'), JSON.stringify(replies[0]));
    check(replies[1].type === 'error' && replies[1].message.includes('hello.colour: unknown field'),
      JSON.stringify(replies[1]));
    check(replies[2].type === 'scenes' && replies[2].scenes.some((scene) => scene.id === sceneId),
      JSON.stringify(replies[2]));

    // The ring scene's own point light has a handle, and no viewer light is offered.
    check(before.lights.length === 1 && before.lights[0].name === 'key light' &&
      !before.lights[0].viewer_light, `lights: ${JSON.stringify(before.lights)}`);
    check(await page.locator('#handles .handle:not(.placed)').count() === 1, 'no handle for the scene light');
    check((await page.textContent('#light-list')).includes('key light'), 'the light is not listed');
    check(await page.locator('#lights-note').isHidden(), 'the viewer-light note shows');
    check(await page.locator('#emitters-panel').isHidden(), 'an area-light panel without area lights');

    // Drag its handle (at the picture's edge: the light is outside it) over the ring.
    const light = before.lights.find((l) => l.draggable && l.visible);
    check(light, `no draggable light: ${JSON.stringify(before.lights)}`);
    await dragHandle(page, light.index, 0.6, 0.25);
    await page.waitForFunction(() => window.causticaViewer.latencies.length >= 1, null, { timeout: 120000 });
    await waitForLightsAfter(page, before.lastFrame.epochs.lights);
    const after = await page.evaluate(() => window.causticaViewer);
    check(after.errors.length === 0, `errors after the drag: ${JSON.stringify(after.errors)}`);
    check(after.lastFrame.epochs.lights > before.lastFrame.epochs.lights, 'the lights epoch did not change');
    const difference = meanDifference(pixelsBefore, await canvasPixels(page));
    check(difference > 1, `the picture barely changed (mean difference ${difference.toFixed(3)})`);
    const movedLight = after.lights[light.index];
    check(Math.abs(movedLight.u - 0.6) < 0.02 && Math.abs(movedLight.v - 0.25) < 0.02,
      `the light did not move where it was dropped: ${JSON.stringify(movedLight)}`);
    check(after.lights.length === 1 && movedLight.name === light.name && !movedLight.viewer_light,
      `the drag did not move the scene's own light: ${JSON.stringify(after.lights)}`);
    check(after.selected === light.index, `the slider scales light ${after.selected}`);
    const latencyText = await page.textContent('#latency');
    check(/drag → frame: last \d+ ms/.test(latencyText), `latency text: ${latencyText}`);
    check(after.latencies.every((ms) => Number.isFinite(ms) && ms >= 0), 'latencies');
    check(page.pageErrors.length === 0, `page errors: ${page.pageErrors.join('; ')}`);
    if (process.env.CAUSTICA_VIEWER_SCREENSHOT) {
      await page.screenshot({ path: process.env.CAUSTICA_VIEWER_SCREENSHOT, fullPage: true });
    }
    // The wheel zooms and a right-button drag orbits: each a new camera epoch in the picture.
    const box = await page.locator('#frame').boundingBox();
    const cameraEpoch = after.lastFrame.epochs.camera;
    await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
    await page.mouse.wheel(0, -120);
    await page.waitForFunction((epoch) => window.causticaViewer.lastFrame.epochs.camera > epoch,
      cameraEpoch, { timeout: 60000 });
    const zoomedEpoch = await page.evaluate(() => window.causticaViewer.lastFrame.epochs.camera);
    await page.mouse.down({ button: 'right' });
    await page.mouse.move(box.x + box.width * 0.6, box.y + box.height / 2, { steps: 3 });
    await page.mouse.up({ button: 'right' });
    await page.waitForFunction((epoch) => window.causticaViewer.lastFrame.epochs.camera > epoch,
      zoomedEpoch, { timeout: 60000 });
    const moved = await page.evaluate(() => window.causticaViewer.errors);
    check(moved.length === 0, `errors after zoom and orbit: ${JSON.stringify(moved)}`);

    // The Cornell box has only its area light: the viewer offers its own light (a dashed
    // handle), whose first drag adds it, and the area-light panel switches the area light.
    const boxId = await upload(server, 'box-small', undefined, smallScene('cornell-box', 128, 128));
    await page.goto(`${server.url}?scene=${boxId}&passes=${PASSES}`);
    await page.waitForFunction(() => window.causticaViewer.idle && window.causticaViewer.framesDrawn >= 1,
      null, { timeout: 120000 });
    const lit = await page.evaluate(() => window.causticaViewer);
    check(lit.lights.length === 1 && lit.lights[0].viewer_light, `box lights: ${JSON.stringify(lit.lights)}`);
    check(lit.emitters.length === 1 && lit.emitters[0].on, `box emitters: ${JSON.stringify(lit.emitters)}`);
    check(await page.locator('#handles .handle.placed').count() === 1, 'no dashed handle');
    check(await page.locator('#lights-note').isVisible(), 'the viewer-light note is hidden');
    await dragHandle(page, lit.lights[0].index, lit.lights[0].u - 0.1, lit.lights[0].v + 0.05);
    await waitForLightsAfter(page, lit.lastFrame.epochs.lights);
    const added = await page.evaluate(() => window.causticaViewer);
    check(added.lights.length === 1 && !added.lights[0].viewer_light && added.lights[0].name === 'viewer light',
      `the viewer light was not added: ${JSON.stringify(added.lights)}`);
    const pixelsOn = await canvasPixels(page);
    const toggleLatencies = added.latencies.length;
    await page.locator('#emitter-list .emitter-on').first().uncheck();
    await waitForLightsAfter(page, added.lastFrame.epochs.lights);
    const switched = await page.evaluate(() => window.causticaViewer);
    check(switched.errors.length === 0, `errors after the switch: ${JSON.stringify(switched.errors)}`);
    check(!switched.emitters[0].on, `the area light is still on: ${JSON.stringify(switched.emitters)}`);
    check(switched.latencies.length > toggleLatencies, 'the switch measured no latency');
    const pixelsOff = await canvasPixels(page);
    const darkening = mean(pixelsOff) / mean(pixelsOn);
    check(darkening < 0.9, `the picture did not darken (mean ${mean(pixelsOn).toFixed(1)} -> ${mean(pixelsOff).toFixed(1)})`);
    check(page.pageErrors.length === 0, `page errors: ${page.pageErrors.join('; ')}`);

    // The same box under a sky: the environment panel shows, and its intensity slider, two stops
    // up, sets the environment four times as bright and brightens the picture.
    const skyScene = JSON.parse(readFileSync(smallScene('cornell-box', 128, 128), 'utf8'));
    skyScene.environment = { color: [0.4, 0.5, 0.7] };
    const skyFile = path.join(dir, 'cornell-box-sky.json');
    writeFileSync(skyFile, JSON.stringify(skyScene));
    const skyId = await upload(server, 'box-sky', undefined, skyFile);
    await page.goto(`${server.url}?scene=${skyId}&passes=${PASSES}`);
    await page.waitForFunction(() => window.causticaViewer.idle && window.causticaViewer.framesDrawn >= 1,
      null, { timeout: 120000 });
    const skyLit = await page.evaluate(() => window.causticaViewer);
    check(skyLit.environment && skyLit.environment.intensity === 1, `environment: ${JSON.stringify(skyLit.environment)}`);
    check(await page.locator('#environment-panel').isVisible(), 'the environment panel is hidden');
    const pixelsSky = await canvasPixels(page);
    await page.locator('#environment-intensity').fill('2');
    await waitForLightsAfter(page, skyLit.lastFrame.epochs.lights);
    const brighter = await page.evaluate(() => window.causticaViewer);
    check(brighter.errors.length === 0, `errors after the sky change: ${JSON.stringify(brighter.errors)}`);
    check(Math.abs(brighter.environment.intensity - 4) < 1e-3, `environment: ${JSON.stringify(brighter.environment)}`);
    check(mean(await canvasPixels(page)) > 1.05 * mean(pixelsSky), 'the brighter sky did not brighten the picture');
    check(page.pageErrors.length === 0, `page errors: ${page.pageErrors.join('; ')}`);

    // The drag bench (scripts/viewer-latency's page mode): a few moves of the ring's light, and
    // one console line with the figures.
    const benchLines = [];
    const onConsole = (message) => {
      if (message.text().startsWith('caustica-drag-bench')) benchLines.push(message.text());
    };
    page.on('console', onConsole);
    await page.goto(`${server.url}?scene=${sceneId}&passes=1&bench=drag&moves=3`);
    await page.waitForFunction(() => document.title.startsWith('caustica-drag-bench '), null, { timeout: 60000 });
    page.off('console', onConsole);
    check(benchLines.length === 1 && benchLines[0].startsWith('caustica-drag-bench {'),
      `bench lines: ${JSON.stringify(benchLines)}`);
    const bench = JSON.parse(benchLines[0].slice('caustica-drag-bench '.length));
    check(bench.moves === 3 && bench.median_ms > 0 && bench.min_ms <= bench.median_ms &&
      bench.median_ms <= bench.max_ms && bench.width === WIDTH && bench.height === HEIGHT &&
      bench.encoding === 'jpeg' && bench.median_decode_ms >= 0 && bench.median_draw_ms >= 0 &&
      Number.isFinite(bench.server_median_ms.render_ms), `bench: ${benchLines[0]}`);
    check(await page.title() === 'caustica-drag-bench done', `title: ${await page.title()}`);
    await page.goto(`${server.url}?scene=${sceneId}&bench=drag&moves=0`);
    await page.waitForFunction(() => document.title === 'caustica-drag-bench error', null, { timeout: 10000 });

    // SIGTERM while a page streams: the server ends the socket and its stream and exits 0.
    await page.goto(`${server.url}?scene=${sceneId}&passes=60000`);
    await page.waitForFunction(() => window.causticaViewer.framesDrawn >= 2, null, { timeout: 60000 });
    const stopStarted = Date.now();
    const code = await stopServer(server);
    check(code === 0, `caustica-server exited with ${code} while a page streamed; its log:\n${server.process.log}`);
    await page.waitForFunction(() => !window.causticaViewer.connected, null, { timeout: 10000 });
    const stopSeconds = (Date.now() - stopStarted) / 1000;
    check(stopSeconds < 10, `shutdown took ${stopSeconds} s`);
    const sorted = [...after.latencies].sort((a, b) => a - b);
    console.log(JSON.stringify({
      scene: 'ring', width: WIDTH, height: HEIGHT, photons_per_pass: PHOTONS,
      latencies_ms: after.latencies.map((ms) => Math.round(ms)),
      median_ms: Math.round(sorted[Math.floor(sorted.length / 2)]),
      frames_drawn: after.framesDrawn, mean_pixel_difference: Number(difference.toFixed(2)),
      area_light_off_ms: Math.round(switched.latencies[switched.latencies.length - 1]),
      area_light_off_brightness: Number(darkening.toFixed(2)),
      bench_median_ms: bench.median_ms, bench_decode_ms: bench.median_decode_ms, shutdown_s: stopSeconds,
    }));
  } finally {
    await browser.close();
    const code = await stopServer(server);
    if (code !== 0) fail(`caustica-server exited with ${code}; its log:\n${server.process.log}`);
  }
}

async function tokensTest() {
  const tokens = path.join(dir, 'tokens.csv');
  const alice = 'alice-token-0123456789', bob = 'bob-token-0123456789ab';
  writeFileSync(tokens, `${alice},alice\n${bob},bob\n`);
  const server = await startServer(['--tokens', tokens]);
  const { browser, page } = await launch();
  try {
    const aliceScene = await upload(server, 'alice-ring', alice);
    const bobScene = await upload(server, 'bob-ring', bob);

    // No token: the page shows the refusal gRPC gives a client that sends none.
    await page.goto(`${server.url}?scene=${aliceScene}`);
    await page.waitForFunction(() => window.causticaViewer.errors.length >= 1, null, { timeout: 30000 });
    const refused = await page.evaluate(() => window.causticaViewer);
    const refusal = refused.errors[0];
    check(refusal.code === 'UNAUTHENTICATED', `code ${refusal.code}`);
    check(refusal.message.includes("missing 'authorization' header"), `message ${refusal.message}`);
    const grpcRefusal = await cliOutput(server, ['scene', 'list']);
    const refusalText = refusal.message.replace(/^ListScenes: /, '');
    check(grpcRefusal.includes(refusalText), `gRPC said:\n${grpcRefusal}\nthe page said:\n${refusalText}`);
    check((await page.textContent('#error')).includes(refusalText), 'the refusal is not shown');
    check(refused.scenes.length === 0 && refused.framesDrawn === 0, 'a refused page got scenes or frames');

    // A wrong token is refused too.
    await page.goto(`${server.url}?token=not-a-token-of-anyone`);
    await page.waitForFunction(() => window.causticaViewer.errors.length >= 1, null, { timeout: 30000 });
    const wrong = await page.evaluate(() => window.causticaViewer.errors[0]);
    check(wrong.code === 'UNAUTHENTICATED' && wrong.message.includes('unknown token'), JSON.stringify(wrong));

    // Alice's token: her scene only, and the token is gone from the address bar.
    await page.goto(`${server.url}?token=${alice}`);
    await page.waitForFunction(() => window.causticaViewer.scenes.length >= 1 ||
      window.causticaViewer.errors.length >= 1, null, { timeout: 30000 });
    const listed = await page.evaluate(() => window.causticaViewer);
    check(listed.errors.length === 0, `errors: ${JSON.stringify(listed.errors)}`);
    const ids = listed.scenes.map((scene) => scene.id);
    check(ids.length === 1 && ids[0] === aliceScene && !ids.includes(bobScene), `alice sees ${ids}`);
    check(!page.url().includes(alice), `the token stayed in the URL: ${page.url()}`);
    const options = await page.locator('#scene-list option').allTextContents();
    check(options.length === 1 && options[0].includes('alice-ring'), `listed: ${options}`);

    // Bob's scene is not found for Alice, as over gRPC.
    await page.goto(`${server.url}?token=${alice}&scene=${bobScene}`);
    await page.waitForFunction(() => window.causticaViewer.errors.length >= 1, null, { timeout: 30000 });
    const notHers = await page.evaluate(() => window.causticaViewer.errors[0]);
    check(notHers.code === 'NOT_FOUND', JSON.stringify(notHers));
    check(page.pageErrors.length === 0, `page errors: ${page.pageErrors.join('; ')}`);
    console.log(JSON.stringify({ refusal: refusal.message, alice_scenes: ids }));
  } finally {
    await browser.close();
    const code = await stopServer(server);
    if (code !== 0) fail(`caustica-server exited with ${code}; its log:\n${server.process.log}`);
  }
}

const tests = { frames: framesTest, tokens: tokensTest };
if (!tests[mode]) {
  console.error(`unknown test '${mode}' (frames or tokens)`);
  process.exit(2);
}
try {
  await tests[mode]();
  if (!process.exitCode) console.log(`PASS: viewer ${mode}`);
} catch (error) {
  if (!process.exitCode) console.error(`FAIL: ${error.stack || error}`);
  process.exitCode = 1;
}

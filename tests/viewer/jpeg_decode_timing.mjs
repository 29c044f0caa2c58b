// How long the viewer page takes to show one JPEG frame: the same createImageBitmap and drawImage
// the page does (www/viewer.js), in Debian's headless chromium, timed in the page over --runs
// decodes of one file after a warm-up. The browser's share of the drag-to-frame latency on a host
// where no browser can run (docs/viewer.md).
//   node tests/viewer/jpeg_decode_timing.mjs FRAME.jpg [--runs N]
import { readFileSync } from 'node:fs';
import { chromium } from 'playwright-core';

const file = process.argv[2];
if (!file) {
  console.error('usage: node jpeg_decode_timing.mjs FRAME.jpg [--runs N]');
  process.exit(2);
}
const runsAt = process.argv.indexOf('--runs');
const runs = runsAt > 0 ? Number(process.argv[runsAt + 1]) : 30;
const bytes = readFileSync(file).toString('base64');

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  headless: true,
  args: ['--no-sandbox', '--disable-gpu', '--disable-dev-shm-usage'],
});
const page = await browser.newPage();
const result = await page.evaluate(async ({ bytes, runs }) => {
  const data = Uint8Array.from(atob(bytes), (c) => c.charCodeAt(0));
  const canvas = document.createElement('canvas');
  document.body.appendChild(canvas);
  const context = canvas.getContext('2d');
  const times = [];
  for (let i = 0; i < runs + 5; ++i) {
    const start = performance.now();
    const bitmap = await createImageBitmap(new Blob([data], { type: 'image/jpeg' }));
    canvas.width = bitmap.width;
    canvas.height = bitmap.height;
    context.drawImage(bitmap, 0, 0);
    context.getImageData(0, 0, 1, 1);  // waits for the draw to land
    bitmap.close();
    if (i >= 5) times.push(performance.now() - start);
  }
  times.sort((a, b) => a - b);
  return { width: canvas.width, height: canvas.height, runs: times.length,
           median_ms: times[Math.floor(times.length / 2)], min_ms: times[0],
           max_ms: times[times.length - 1] };
}, { bytes, runs });
await browser.close();
console.log(JSON.stringify({ name: 'jpeg_decode_draw', file, bytes: Buffer.from(bytes, 'base64').length, ...result }));

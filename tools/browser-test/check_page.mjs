// Opens a page `portcullis view` wrote in headless Chromium (Debian's, through playwright-core)
// from a file URL, and prints what a test needs as one JSON object on stdout:
//   node check_page.mjs PAGE.html SHOT.png [CELL ...]
// { errors: [console errors and page errors], ready, cells, portals, selected: {cell: [lit]},
//   shot: {pixels, background, colours}, readyMs }
// The browser is found at $CHROMIUM, else /usr/bin/chromium.
import { chromium } from 'playwright-core';
import { pathToFileURL } from 'node:url';
import { resolve } from 'node:path';

const [page, shot, ...cells] = process.argv.slice(2);
const executablePath = process.env.CHROMIUM || '/usr/bin/chromium';
const browser = await chromium.launch({
  executablePath,
  headless: true,
  args: [
    '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
    '--disable-quic', '--no-first-run', '--disable-background-networking',
    '--disable-component-update', '--disable-sync',
  ],
});
const out = { errors: [], selected: {} };
try {
  const tab = await browser.newPage({ viewport: { width: 1100, height: 700 } });
  tab.on('console', (m) => { if (m.type() === 'error') out.errors.push(m.text()); });
  tab.on('pageerror', (e) => out.errors.push(String(e)));
  // Anything the page asks of the network is an error: it must open offline.
  await tab.route((url) => !url.protocol.startsWith('file'), (route) => {
    out.errors.push('network request: ' + route.request().url());
    return route.abort();
  });
  const start = Date.now();
  await tab.goto(pathToFileURL(resolve(page)).href);
  await tab.waitForFunction(() => window.portcullis && window.portcullis.ready, null, { timeout: 60000 });
  out.readyMs = Date.now() - start;
  const state = await tab.evaluate(() => ({ cells: window.portcullis.cells, portals: window.portcullis.portals }));
  Object.assign(out, state, { ready: true });
  out.diagnostics = await tab.evaluate(() => (document.getElementById('diagnostics') || {}).textContent || '');
  for (const c of cells) {
    out.selected[c] = await tab.evaluate((c) => window.portcullis.select(c), Number(c));
  }
  // Back to no selection for the picture, then two frames so it is drawn.
  await tab.evaluate(() => window.portcullis.select(null));
  await tab.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
  if (shot) {
    await tab.locator('#view canvas').screenshot({ path: shot });
    // What the canvas holds: how many pixels differ from the background, and how many colours.
    out.shot = await tab.evaluate(() => {
      const src = document.querySelector('#view canvas');
      const c = document.createElement('canvas');
      c.width = 200; c.height = Math.max(1, Math.round(200 * src.height / src.width));
      const g = c.getContext('2d');
      g.drawImage(src, 0, 0, c.width, c.height);
      const d = g.getImageData(0, 0, c.width, c.height).data;
      const bg = [d[0], d[1], d[2]];
      let differ = 0;
      const colours = new Set();
      for (let i = 0; i < d.length; i += 4) {
        if (Math.abs(d[i] - bg[0]) + Math.abs(d[i + 1] - bg[1]) + Math.abs(d[i + 2] - bg[2]) > 24) differ++;
        colours.add((d[i] >> 4) + ',' + (d[i + 1] >> 4) + ',' + (d[i + 2] >> 4));
      }
      return { pixels: d.length / 4, differ, colours: colours.size };
    });
  }
} catch (e) {
  out.errors.push('driver: ' + String(e));
} finally {
  await browser.close();
}
process.stdout.write(JSON.stringify(out) + '\n');

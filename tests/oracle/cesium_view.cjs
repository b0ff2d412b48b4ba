#!/usr/bin/env node
// Oracle for `skylod convert --viewer`: opens DIR/index.html in headless Chromium
// (npm `playwright-core` driving Debian's /usr/bin/chromium, WebGL through SwiftShader)
// and checks that CesiumJS shows the tileset.
//
//   NODE_PATH=/path/to/node_modules node tests/oracle/cesium_view.cjs DIR OUT.png
//
// DIR is served by a small HTTP server on 127.0.0.1. The page loads CesiumJS from
// https://cesium.com/downloads/cesiumjs/releases/<version>/Build/Cesium/; those
// requests, whatever the version, are answered from the npm `cesium` package's
// Build/Cesium/ (found through NODE_PATH); every other external request (imagery, ...)
// is aborted, and the console errors those aborts cause are not reported.
//
// Waits for window.skylodReady (or window.skylodError), then for the tileset to finish
// loading and a few frames, saves a screenshot to OUT.png, picks the feature at the
// screen centre, hides the tileset (skylodTileset.show = false) and counts the pixels
// that differ from the screenshot with it shown. Prints one JSON object:
//   {"loaded", "error", "console_errors", "changed_pixels", "picked_gml_id",
//    "picked_class", "tiles_loaded", "features_loaded", "webgl_renderer",
//    "aborted_requests", "aborted_hosts", "seconds"}
// tiles_loaded counts tiles whose content is loaded (with REPLACE refinement a refined
// parent stays loaded), features_loaded the sum of their featuresLength.
// Exits 0 when it could run at all (the Rust test asserts), 2 otherwise.
// Environment: CHROMIUM (default /usr/bin/chromium), SKYLOD_VIEW_TIMEOUT_MS (default 180000).
'use strict';

const fs = require('fs');
const http = require('http');
const os = require('os');
const path = require('path');

const started = Date.now();
const TIMEOUT = Number(process.env.SKYLOD_VIEW_TIMEOUT_MS || 180000);
const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
const WIDTH = 800;
const HEIGHT = 600;
const CDN = /^https:\/\/cesium\.com\/downloads\/cesiumjs\/releases\/[^/]+\/Build\/Cesium\/([^?#]*)/;
const MIME = {
  '.json': 'application/json', '.glb': 'model/gltf-binary', '.gltf': 'model/gltf+json',
  '.html': 'text/html; charset=utf-8', '.js': 'text/javascript', '.mjs': 'text/javascript',
  '.css': 'text/css', '.wasm': 'application/wasm', '.png': 'image/png', '.jpg': 'image/jpeg',
  '.svg': 'image/svg+xml', '.ktx2': 'image/ktx2', '.subtree': 'application/octet-stream',
  '.xml': 'application/xml', '.txt': 'text/plain',
};
const mime = (p) => MIME[path.extname(p).toLowerCase()] || 'application/octet-stream';

// A file under root for a URL path, or null if it escapes root or does not exist.
function fileUnder(root, urlPath) {
  let rel;
  try { rel = decodeURIComponent(urlPath); } catch (_) { return null; }
  const file = path.resolve(root, '.' + path.posix.normalize('/' + rel));
  if (file !== root && !file.startsWith(root + path.sep)) return null;
  try { return fs.statSync(file).isFile() ? file : null; } catch (_) { return null; }
}

function serve(root) {
  const server = http.createServer((req, res) => {
    const file = fileUnder(root, new URL(req.url, 'http://x').pathname);
    if (!file) { res.writeHead(404, { 'Content-Type': 'text/plain' }); res.end('not found'); return; }
    res.writeHead(200, { 'Content-Type': mime(file), 'Cache-Control': 'no-store' });
    fs.createReadStream(file).pipe(res);
  });
  return new Promise((resolve) => server.listen(0, '127.0.0.1', () => resolve(server)));
}

function cesiumBuildDir() {
  const pkg = require.resolve('cesium/package.json');
  const dir = path.join(path.dirname(pkg), 'Build', 'Cesium');
  if (!fs.existsSync(path.join(dir, 'Cesium.js'))) throw new Error(`no Cesium build at ${dir}`);
  return dir;
}

// Resolves after n rendered frames of the page's viewer.
const frames = (page, n) => page.evaluate((n) => new Promise((resolve) => {
  let left = n;
  const scene = window.skylodViewer.scene;
  const off = scene.postRender.addEventListener(() => { if (--left <= 0) { off(); resolve(); } });
  scene.requestRender();
}), n);

// Number of pixels whose colour differs (any channel by more than 16) between two PNGs.
const diffPixels = (page, a, b) => page.evaluate(async ([a, b]) => {
  const pixels = async (b64) => {
    const bmp = await createImageBitmap(await (await fetch('data:image/png;base64,' + b64)).blob());
    const c = new OffscreenCanvas(bmp.width, bmp.height);
    const g = c.getContext('2d');
    g.drawImage(bmp, 0, 0);
    return g.getImageData(0, 0, bmp.width, bmp.height).data;
  };
  const [p, q] = [await pixels(a), await pixels(b)];
  if (p.length !== q.length) return -1;
  let n = 0;
  for (let i = 0; i < p.length; i += 4) {
    if (Math.abs(p[i] - q[i]) > 16 || Math.abs(p[i + 1] - q[i + 1]) > 16 || Math.abs(p[i + 2] - q[i + 2]) > 16) n++;
  }
  return n;
}, [a.toString('base64'), b.toString('base64')]);

async function main() {
  const [dirArg, outPng] = process.argv.slice(2);
  if (!dirArg || !outPng || !fs.existsSync(path.join(dirArg, 'index.html'))) {
    process.stderr.write('usage: cesium_view.cjs DIR OUT.png (DIR must hold index.html)\n');
    process.exit(2);
  }
  const root = fs.realpathSync(dirArg);
  const cesiumDir = cesiumBuildDir();
  const { chromium } = require('playwright-core');

  const result = {
    loaded: false, error: null, console_errors: [], changed_pixels: 0, picked_gml_id: null,
    picked_class: null, tiles_loaded: 0, features_loaded: 0, webgl_renderer: null,
    aborted_requests: 0, aborted_hosts: [], seconds: 0,
  };
  const server = await serve(root);
  const origin = `http://127.0.0.1:${server.address().port}`;
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'skylod-chromium-'));
  let context;
  try {
    context = await chromium.launchPersistentContext(profile, {
      executablePath: CHROMIUM,
      headless: true,
      viewport: { width: WIDTH, height: HEIGHT },
      deviceScaleFactor: 1,
      args: [
        '--headless', '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader',
        '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--disable-background-networking',
        '--disable-component-update', '--disable-sync', '--disable-quic', '--no-first-run',
        '--disable-default-apps', '--disable-extensions', '--mute-audio',
      ],
    });
  } catch (err) {
    server.close();
    fs.rmSync(profile, { recursive: true, force: true });
    process.stderr.write(`cesium_view.cjs: cannot launch ${CHROMIUM}: ${err.message}\n`);
    process.exit(2);
  }

  const aborted = new Set();
  await context.route('**/*', async (route) => {
    const url = route.request().url();
    if (url.startsWith(origin + '/') || url.startsWith('data:') || url.startsWith('blob:')) return route.continue();
    const m = CDN.exec(url);
    const file = m && fileUnder(cesiumDir, '/' + m[1]);
    if (file) {
      return route.fulfill({
        status: 200, body: fs.readFileSync(file),
        headers: { 'Content-Type': mime(file), 'Access-Control-Allow-Origin': '*' },
      });
    }
    aborted.add(url);
    return route.abort('blockedbyclient');
  });

  const page = context.pages()[0] || (await context.newPage());
  page.on('console', (msg) => {
    if (msg.type() !== 'error') return;
    const at = msg.location() && msg.location().url;
    if (at && aborted.has(at) && /Failed to load resource/.test(msg.text())) return;
    result.console_errors.push(msg.text());
  });
  page.on('pageerror', (err) => result.console_errors.push(String(err && err.stack ? err.stack : err)));

  try {
    await page.goto(origin + '/index.html', { waitUntil: 'load', timeout: TIMEOUT });
    await page.waitForFunction(() => window.skylodReady === true || typeof window.skylodError === 'string',
      null, { timeout: TIMEOUT, polling: 250 });
    result.error = await page.evaluate(() => (typeof window.skylodError === 'string' ? window.skylodError : null));
    if (!result.error) {
      await page.waitForFunction(() => window.skylodTileset.tilesLoaded, null, { timeout: TIMEOUT, polling: 250 });
      await frames(page, 5);
      Object.assign(result, await page.evaluate(() => {
        const tileset = window.skylodTileset;
        let tiles = 0, features = 0;
        const stack = [tileset.root];
        while (stack.length) {
          const tile = stack.pop();
          if (tile.contentReady && tile.content) { tiles++; features += tile.content.featuresLength || 0; }
          stack.push(...(tile.children || []));
        }
        const gl = window.skylodViewer.scene.context._gl;
        const ext = gl && gl.getExtension('WEBGL_debug_renderer_info');
        return {
          tiles_loaded: tiles, features_loaded: features,
          webgl_renderer: gl ? String(gl.getParameter(ext ? ext.UNMASKED_RENDERER_WEBGL : gl.RENDERER)) : null,
        };
      }));
      const shown = await page.screenshot({ path: outPng });
      Object.assign(result, await page.evaluate(() => {
        const scene = window.skylodViewer.scene;
        const f = scene.pick(new Cesium.Cartesian2(scene.canvas.clientWidth / 2, scene.canvas.clientHeight / 2));
        const get = (k) => (f && typeof f.getProperty === 'function' && f.getProperty(k) != null ? String(f.getProperty(k)) : null);
        return { picked_gml_id: get('gml_id'), picked_class: get('class') };
      }));
      await page.evaluate(() => { window.skylodTileset.show = false; });
      await frames(page, 5);
      const hidden = await page.screenshot();
      await page.evaluate(() => { window.skylodTileset.show = true; });
      result.changed_pixels = await diffPixels(page, shown, hidden);
      result.loaded = result.tiles_loaded > 0;
    } else {
      await page.screenshot({ path: outPng });
    }
  } catch (err) {
    result.error = result.error || String(err && err.message ? err.message : err).split('\n')[0];
    try { await page.screenshot({ path: outPng }); } catch (_) { /* page gone */ }
  } finally {
    result.aborted_requests = aborted.size;
    result.aborted_hosts = [...new Set([...aborted].map((u) => { try { return new URL(u).host; } catch (_) { return u; } }))].sort();
    await context.close().catch(() => {});
    server.close();
    fs.rmSync(profile, { recursive: true, force: true });
  }
  result.seconds = Math.round((Date.now() - started) / 100) / 10;
  process.stdout.write(JSON.stringify(result) + '\n');
}

main().catch((err) => {
  process.stderr.write(`cesium_view.cjs: ${err && err.stack ? err.stack : err}\n`);
  process.exit(2);
});

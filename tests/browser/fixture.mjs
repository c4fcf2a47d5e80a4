// What the browser tests share: ajard on simulated hardware + ajar-console on the simulated camera
// (each test its own pair when it stops or kills one), Debian's headless Chromium driven by
// playwright-core (no browser is downloaded), the page's helpers (clicks at the scenario's
// landmarks, steps, sending), the three screen sizes, screenshots and axe-core.
//
// Env: AJAR_BUILD_DIR (default build), AJAR_CHROMIUM (default /usr/bin/chromium), AJAR_CONSOLE_WEB
// (another web folder for the console: how the tests were run against the page before issue 23),
// AJAR_AJARD (another ajard binary).
// Screenshots: $AJAR_BUILD_DIR/browser-artifacts/*.png
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { mkdtempSync, mkdirSync, readFileSync, writeFileSync, existsSync, rmSync } from 'node:fs';
import { createRequire } from 'node:module';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

export const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
export const build = path.resolve(root, process.env.AJAR_BUILD_DIR || 'build');
export const artifacts = path.join(build, 'browser-artifacts');
const executablePath = process.env.AJAR_CHROMIUM || '/usr/bin/chromium';
export const scenarioPath = path.join(root, 'config/scenarios/console-door.yaml');
export const VIEWPORTS = [
  { name: '1280x720', width: 1280, height: 720 },
  { name: '1920x1080', width: 1920, height: 1080 },
  { name: '800x600', width: 800, height: 600 },
];

// The scenario's truth, read from the same YAML the console renders.
export function scenarioNumber(key) {
  const m = new RegExp(`^\\s*${key}:\\s*([-0-9.]+)`, 'm').exec(readFileSync(scenarioPath, 'utf8'));
  assert.ok(m, `${key} in ${scenarioPath}`);
  return Number(m[1]);
}

function start(cmd, args, name) {
  const child = spawn(cmd, args, { stdio: ['ignore', 'pipe', 'pipe'] });
  child.output = '';
  child.stdout.on('data', (d) => { child.output += d; });
  child.stderr.on('data', (d) => { child.output += d; });
  child.name = name;
  return child;
}
export async function until(what, fn, timeoutMs = 15000) {
  const end = Date.now() + timeoutMs;
  for (;;) {
    const v = await fn();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out waiting for ${what}`);
    await new Promise((r) => setTimeout(r, 100));
  }
}
export function stopped(child, timeoutMs) {
  return new Promise((resolve) => {
    if (child.exitCode !== null || child.signalCode !== null) return resolve(true);
    const t = setTimeout(() => resolve(false), timeoutMs);
    child.on('exit', () => { clearTimeout(t); resolve(true); });
  });
}

let browser = null;
const pages = new Set();
// After a failure: a screenshot and the event log of every page still open.
export async function dumpPages(name) {
  for (const P of pages) {
    await P.page.screenshot({ path: path.join(artifacts, `failure-${name}.png`) }).catch(() => {});
    const log = await P.page.textContent('#log').catch(() => '');
    console.error(`--- page event log (${name}) ---\n${String(log).slice(-2500)}`);
  }
}
export async function theBrowser() {
  assert.ok(existsSync(executablePath), `${executablePath} (apt install chromium)`);
  if (!browser) {
    browser = await chromium.launch({
      executablePath,
      headless: true,
      args: ['--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update',
        '--disable-sync', '--no-first-run'],
    });
  }
  return browser;
}
export async function closeBrowser() { if (browser) await browser.close().catch(() => {}); browser = null; }

// ajard + ajar-console; `stack.stop()` ends both (and prints their output when a test failed).
// `ajardConfig(yaml)` may change the shipped config's text (e.g. turn the black box off).
export async function startStack(name, { consoleArgs = [], ajardConfig = (yaml) => yaml } = {}) {
  mkdirSync(artifacts, { recursive: true });
  const work = mkdtempSync(path.join(tmpdir(), 'ajar-browser-'));
  const portFile = path.join(work, 'port');
  const stack = { name, work };
  // The shipped simulated robot, its control loop realtime (SCHED_FIFO, as on the robot; refused
  // where not allowed, with a warning) and the loop's stall detector relaxed to 0.5 s (its
  // maximum): on 2 cores shared with Chromium, a scheduling gap of the control thread is not what
  // these tests test (LOOP_STALLED has its own tests in tests/daemon and tests/drivers); a
  // SCHED_OTHER thread's wait for a CPU is excused only up to 0.75 s of silence, and a VM's vCPU
  // taken away is seen by no one.
  const config = path.join(work, 'ajard.yaml');
  writeFileSync(config, ajardConfig(readFileSync(path.join(root, 'config/ajard.yaml'), 'utf8')
    .replace(/^(\s*stall_timeout_s:\s*)[0-9.]+/m, (_, key) => `${key}0.5`)
    .replace(/^(\s*realtime:\s*)false/m, (_, key) => `${key}true`)));
  stack.ajard = start(process.env.AJAR_AJARD || path.join(build, 'daemon/ajard'), ['--config', config,
    '--listen', '127.0.0.1:0', '--port-file', portFile, '--state-dir', path.join(work, 'state')], 'ajard');
  stack.daemonPort = await until('ajard port file', () => existsSync(portFile) && readFileSync(portFile, 'utf8').trim());
  stack.console = start(path.join(build, 'console/ajar-console'), ['--connect', `127.0.0.1:${stack.daemonPort}`,
    '--listen', '127.0.0.1:0', '--scenario', scenarioPath,
    ...(process.env.AJAR_CONSOLE_WEB ? ['--web', process.env.AJAR_CONSOLE_WEB] : []), ...consoleArgs], 'ajar-console');
  stack.url = await until('the console URL', () => (/open (http:\/\/\S+)/.exec(stack.console.output) || [])[1]);
  stack.landmarks = async () => (await (await fetch(stack.url + 'api/sim/landmarks')).json());
  stack.apiState = async () => (await (await fetch(stack.url + 'api/state')).json());
  stack.ajarctl = (args) => new Promise((resolve) => {
    const c = start(path.join(build, 'client/ajarctl'), ['--connect', `127.0.0.1:${stack.daemonPort}`, ...args], 'ajarctl');
    c.on('exit', (code) => resolve({ code, output: c.output }));
  });
  stack.stop = async (failed) => {
    for (const p of [stack.console, stack.ajard]) {
      if (!p) continue;
      try { process.kill(p.pid, 'SIGCONT'); } catch { /* gone */ }
    }
    if (failed) {
      console.error('--- ajard ---\n' + stack.ajard.output.slice(-3000));
      console.error('--- ajar-console ---\n' + stack.console.output.slice(-3000));
    }
    stack.console.kill('SIGINT');
    stack.consoleStopped = await stopped(stack.console, 5000);
    if (!stack.consoleStopped) stack.console.kill('SIGKILL');
    stack.ajard.kill('SIGTERM');
    if (!await stopped(stack.ajard, 5000)) stack.ajard.kill('SIGKILL');
    rmSync(work, { recursive: true, force: true });
  };
  return stack;
}

// A page on the console at one of VIEWPORTS, with the helpers the tests use.
export async function openPage(stack, viewport = VIEWPORTS[0]) {
  const b = await theBrowser();
  const context = await b.newContext({ viewport: { width: viewport.width, height: viewport.height } });
  const page = await context.newPage();
  const errors = [];
  page.on('pageerror', (e) => errors.push(e));
  await page.goto(stack.url);
  await page.waitForSelector('#conn.ok', { timeout: 15000 });
  await page.waitForFunction(() => /frame \d+/.test(document.getElementById('frame-info').textContent));
  await page.waitForFunction(() => !document.getElementById('live-badge') || document.getElementById('live-badge').dataset.state === 'live', null, { timeout: 15000 });
  const P = { page, context, errors, stack };
  pages.add(P);
  P.box = async () => (await page.$('#image')).boundingBox();
  // Image pixel -> page coordinates (the image scales with the window).
  P.at = async (p) => {
    await page.$eval('#canvas-wrap', (e) => e.scrollIntoView({ block: 'nearest' }));
    const b2 = await P.box();
    return { x: b2.x + (p.u + 0.5) * b2.width / 640, y: b2.y + (p.v + 0.5) * b2.height / 480 };
  };
  P.clickAt = async (p) => {
    assert.ok(p.u > 2 && p.u < 637 && p.v > 2 && p.v < 477, `landmark in view: ${JSON.stringify(p)}`);
    const q = await P.at(p);
    await page.mouse.click(q.x, q.y);
  };
  P.picks = async (n) => page.waitForFunction((k) => document.querySelectorAll('#pick-list li').length === k, n);
  // Picks on the specular handle can land where too few pixels have depth: the page refuses them
  // and the operator clicks again (a new frame has other holes).
  P.pickOn = async (p, n) => {
    for (let attempt = 0; ; ++attempt) {
      await page.evaluate(() => { document.getElementById('result').dataset.code = ''; });
      await P.clickAt(p);
      const got = await page.waitForFunction((k) => document.querySelectorAll('#pick-list li').length === k ||
        /PICK|FROZEN/.test(document.getElementById('result').dataset.code || ''), n).then(() => page.$$eval('#pick-list li', (l) => l.length));
      if (got === n) return;
      assert.ok(attempt < 4, `pick ${n} refused 5 times: ${await page.textContent('#result')}`);
      await page.waitForTimeout(150);
    }
  };
  P.step = async (name) => {
    await page.click(`#steps button[data-step=${name}]`);
    await page.waitForFunction((s) => document.querySelector(`#steps button[data-step=${s}]`).classList.contains('active'), name);
    await page.click('#btn-clear');
    await P.picks(0);
  };
  P.send = async () => {
    await page.evaluate(() => { document.getElementById('result').dataset.ok = ''; });
    await page.click('#btn-send');
    await page.waitForFunction(() => ['true', 'false'].includes(document.getElementById('result').dataset.ok));
    return { ok: await page.getAttribute('#result', 'data-ok') === 'true', text: await page.textContent('#result'),
      code: await page.getAttribute('#result', 'data-code'), field: await page.getAttribute('#result', 'data-field') };
  };
  P.waitState = (s, timeout = 20000) => page.waitForFunction((x) => document.getElementById('state').textContent === x, s, { timeout });
  P.dragRect = async (a, b2) => {
    const qa = await P.at(a), qb = await P.at(b2);
    await page.mouse.move(qa.x, qa.y);
    await page.mouse.down();
    await page.mouse.move((qa.x + qb.x) / 2, (qa.y + qb.y) / 2, { steps: 4 });
    await page.mouse.move(qb.x, qb.y, { steps: 4 });
    await page.mouse.up();
  };
  P.width = async (L, { reversed = false } = {}) => {
    await P.step('width');
    await P.clickAt(reversed ? L.points.moving_edge : L.points.hinge_edge);
    await P.picks(1);
    await P.clickAt(reversed ? L.points.hinge_edge : L.points.moving_edge);
    await P.picks(2);
    return P.send();
  };
  P.handle = async (L) => {
    await P.step('handle');
    await P.pickOn(L.points.handle_axis, 1);
    await P.pickOn(L.points.handle_free_end, 2);
    return P.send();
  };
  P.planePicks = async (L) => {
    await P.step('plane');
    await P.dragRect({ u: L.points.leaf_low_left.u, v: L.points.leaf_high_middle.v },
      { u: L.points.leaf_low_right.u, v: L.points.leaf_low_left.v });
    await page.waitForFunction(() => document.querySelectorAll('#pick-list li').length >= 12);
  };
  // Log lines after `mark` (the number of lines when it was taken).
  P.logMark = async () => page.$$eval('#log div', (l) => l.length);
  P.logSince = async (mark) => page.$$eval('#log div', (l, m) => l.slice(m).map((d) => d.textContent), mark);
  P.shot = async (name) => {
    await page.evaluate(() => window.scrollTo(0, 0));
    await page.screenshot({ path: path.join(artifacts, `${name}.png`) });
  };
  // The assertion `check(vp)` at each screen size, with a screenshot each.
  P.atEachViewport = async (name, check) => {
    for (const vp of VIEWPORTS) {
      await page.setViewportSize({ width: vp.width, height: vp.height });
      await page.evaluate(() => window.scrollTo(0, 0));  // "above the fold": as the page opens
      await page.waitForTimeout(120);  // one watchdog round and a layout
      await check(vp);
      await P.shot(`${name}-${vp.name}`);
    }
    await page.setViewportSize({ width: VIEWPORTS[0].width, height: VIEWPORTS[0].height });
  };
  // True when the element is entirely inside the viewport (above the fold, not cut off).
  P.inViewport = async (sel) => page.$eval(sel, (e) => {
    const r = e.getBoundingClientRect();
    return r.width > 0 && r.height > 0 && r.top >= 0 && r.left >= 0 && r.bottom <= window.innerHeight + 0.5 && r.right <= window.innerWidth + 0.5;
  });
  // The header pills whose text is cut off (shown with an ellipsis): none may be. `widest` also
  // tries the longest values a pill can hold (the state with a motion, a latched fault) in the same
  // layout, restored before the next watchdog round redraws them.
  P.truncatedPills = async (widest = {}) => page.evaluate((widest) => {
    const saved = Object.keys(widest).map((id) => [id, document.getElementById(id).textContent]);
    for (const [id, text] of Object.entries(widest)) document.getElementById(id).textContent = text;
    const pills = [...document.querySelectorAll('header .pill')].filter((e) => !e.hidden);
    if (pills.length < 4) return [`only ${pills.length} pills in the header`];
    const cut = pills.filter((e) => e.scrollWidth > e.clientWidth + 0.5)
      .map((e) => `${e.id} "${e.textContent.trim().replace(/\s+/g, ' ')}" needs ${e.scrollWidth} px, has ${e.clientWidth}`);
    for (const [id, text] of saved) document.getElementById(id).textContent = text;
    return cut;
  }, widest);
  P.close = async () => { pages.delete(P); await context.close().catch(() => {}); };
  return P;
}

// axe-core (npm, pinned in package-lock.json) run inside the page: the serious and critical ones.
const require = createRequire(import.meta.url);
const axeSource = readFileSync(require.resolve('axe-core/axe.min.js'), 'utf8');
export async function axeViolations(page) {
  await page.addScriptTag({ content: axeSource });
  const result = await page.evaluate(async () => window.axe.run(document, { resultTypes: ['violations'] }));
  return result.violations.filter((v) => v.impact === 'serious' || v.impact === 'critical')
    .map((v) => `${v.id} (${v.impact}): ${v.help}: ${v.nodes.slice(0, 4).map((n) => n.target.join(' ')).join(', ')}`);
}

// Runs `body(stack)` on a fresh ajard + console; prints both processes' output when it fails.
export async function withStack(name, body, options) {
  const stack = await startStack(name, options);
  let failed = true;
  try {
    await body(stack);
    failed = false;
  } finally {
    await stack.stop(failed);
  }
}

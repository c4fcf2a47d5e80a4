// The operator console in a real browser (Debian's headless Chromium, driven by playwright-core;
// no browser is downloaded): ajard on simulated hardware + ajar-console on the simulated camera.
// The test clicks the picks on the camera image and runs the whole procedure, checks the values
// the page shows against the scenario's truth within the noise, presses EMERGENCY STOP mid-
// alignment and sees the fault latch, and checks that closing the page stops feeding the deadman.
//
// Run: scripts/test (stage "browser"), or: node --test tests/browser/
// Env: AJAR_BUILD_DIR (default build), AJAR_CHROMIUM (default /usr/bin/chromium).
// Screenshots: $AJAR_BUILD_DIR/browser-artifacts/*.png
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { mkdtempSync, mkdirSync, readFileSync, existsSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const build = path.resolve(root, process.env.AJAR_BUILD_DIR || 'build');
const artifacts = path.join(build, 'browser-artifacts');
const executablePath = process.env.AJAR_CHROMIUM || '/usr/bin/chromium';
const scenarioPath = path.join(root, 'config/scenarios/console-door.yaml');

// The scenario's truth, read from the same YAML the console renders.
function scenarioNumber(key) {
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
async function until(what, fn, timeoutMs = 15000) {
  const end = Date.now() + timeoutMs;
  for (;;) {
    const v = await fn();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out waiting for ${what}`);
    await new Promise((r) => setTimeout(r, 100));
  }
}
function stopped(child, timeoutMs) {
  return new Promise((resolve) => {
    if (child.exitCode !== null) return resolve(true);
    const t = setTimeout(() => resolve(false), timeoutMs);
    child.on('exit', () => { clearTimeout(t); resolve(true); });
  });
}

test('operator console: the whole procedure by pointing at the simulated camera', { timeout: 240000 }, async () => {
  assert.ok(existsSync(executablePath), `${executablePath} (apt install chromium)`);
  mkdirSync(artifacts, { recursive: true });
  const work = mkdtempSync(path.join(tmpdir(), 'ajar-browser-'));
  const portFile = path.join(work, 'port');
  const ajard = start(path.join(build, 'daemon/ajard'), ['--config', path.join(root, 'config/ajard.yaml'),
    '--listen', '127.0.0.1:0', '--port-file', portFile, '--state-dir', path.join(work, 'state')], 'ajard');
  let consoleProc = null;
  let context = null;
  let consoleStopped = true;
  let page = null;
  let stage = 'start';
  const say = (what) => { stage = what; console.log(`# ${new Date().toISOString().slice(11, 23)} ${what}`); };
  try {
    const port = await until('ajard port file', () => existsSync(portFile) && readFileSync(portFile, 'utf8').trim());
    consoleProc = start(path.join(build, 'console/ajar-console'), ['--connect', `127.0.0.1:${port}`,
      '--listen', '127.0.0.1:0', '--scenario', scenarioPath], 'ajar-console');
    const url = await until('the console URL', () => (/open (http:\/\/\S+)/.exec(consoleProc.output) || [])[1]);

    context = await chromium.launchPersistentContext(path.join(work, 'chromium-profile'), {
      executablePath,
      headless: true,
      viewport: { width: 1500, height: 1150 },
      args: ['--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update',
        '--disable-sync', '--no-first-run'],
    });
    page = context.pages()[0] || await context.newPage();
    page.on('pageerror', (e) => { throw e; });
    await page.goto(url);
    await page.waitForSelector('#conn.ok', { timeout: 15000 });
    await page.waitForFunction(() => /frame \d+/.test(document.getElementById('frame-info').textContent));
    await page.waitForFunction(() => document.getElementById('deadman-text').textContent === 'fed by this page');
    assert.equal(await page.textContent('#role'), 'controller');
    assert.equal(await page.textContent('#state'), 'awaiting_width');
    assert.ok(await page.isVisible('#estop'));
    await page.screenshot({ path: path.join(artifacts, '01-start.png') });

    const canvas = await page.$('#image');
    const box = await canvas.boundingBox();
    const landmarks = async () => (await (await fetch(url + 'api/sim/landmarks')).json());
    const clickAt = async (p) => {
      assert.ok(p.u > 2 && p.u < 637 && p.v > 2 && p.v < 477, `landmark in view: ${JSON.stringify(p)}`);
      await page.mouse.click(box.x + p.u + 0.5, box.y + p.v + 0.5);
    };
    const picks = async (n) => page.waitForFunction((k) => document.querySelectorAll('#pick-list li').length === k, n);
    // Picks on the specular handle can land where too few pixels have depth: the page refuses them
    // ("pick a measurable area") and the operator clicks again (a new frame has other holes).
    const pickOn = async (p, n) => {
      for (let attempt = 0; ; ++attempt) {
        await clickAt(p);
        const got = await page.waitForFunction((k) => document.querySelectorAll('#pick-list li').length === k ||
          /PICK/.test(document.getElementById('result').textContent), n).then(() => page.$$eval('#pick-list li', (l) => l.length));
        if (got === n) return;
        assert.ok(attempt < 3, `pick ${n} refused 4 times: ${await page.textContent('#result')}`);
        await page.evaluate(() => { document.getElementById('result').textContent = ''; });
        await page.waitForTimeout(150);
      }
    };
    const step = async (name) => {
      await page.click(`#steps button[data-step=${name}]`);
      await page.waitForFunction((s) => document.querySelector(`#steps button[data-step=${s}]`).classList.contains('active'), name);
      await page.click('#btn-clear');
      await picks(0);
    };
    const sendAndWait = async () => {
      await page.evaluate(() => { document.getElementById('result').dataset.ok = ''; });
      await page.click('#btn-send');
      await page.waitForFunction(() => ['true', 'false'].includes(document.getElementById('result').dataset.ok));
      return { ok: await page.getAttribute('#result', 'data-ok') === 'true', text: await page.textContent('#result') };
    };
    const waitState = (s, timeout = 20000) => page.waitForFunction((x) => document.getElementById('state').textContent === x, s, { timeout });
    const dragRect = async (a, b) => {
      await page.mouse.move(box.x + a.u, box.y + a.v);
      await page.mouse.down();
      await page.mouse.move(box.x + (a.u + b.u) / 2, box.y + (a.v + b.v) / 2, { steps: 4 });
      await page.mouse.move(box.x + b.u, box.y + b.v, { steps: 4 });
      await page.mouse.up();
    };
    const truth = { width: scenarioNumber('width_m'), handle: scenarioNumber('length_m'), yawDeg: scenarioNumber('yaw_deg') };

    say('hover');
    // Live data follows the cursor: hovering the door shows its camera-frame coordinates.
    let L = await landmarks();
    await page.mouse.move(box.x + L.points.leaf_low_left.u, box.y + L.points.leaf_low_left.v);
    await page.waitForFunction(() => document.getElementById('live-cz').textContent !== '—');
    const cz = Number(await page.textContent('#live-cz'));
    assert.ok(Math.abs(cz - L.points.leaf_low_left.camera_m[2]) < 0.02, `hover depth ${cz}`);
    // Base frame (eq. 1) with the calibration the daemon reports (RobotModel, protocol 1.1).
    await page.waitForFunction(() => /^[-+][0-9.]+$/.test(document.getElementById('live-bx').textContent));
    const bx = Number(await page.textContent('#live-bx'));
    const by = Number(await page.textContent('#live-by'));
    assert.ok(Math.hypot(bx - L.points.leaf_low_left.base_m[0], by - L.points.leaf_low_left.base_m[1]) < 0.03,
      `hover base (${bx}, ${by}) vs truth ${L.points.leaf_low_left.base_m}`);

    say('width refused');
    // 1. Width. First a mistake: P1 and P2 on the same spot -> refused, the field named and the
    // offending pick highlighted; then P1 on the hinge side and P2 at the moving edge.
    await step('width');
    await clickAt(L.points.hinge_edge);
    await picks(1);
    await clickAt(L.points.hinge_edge);
    await picks(2);
    let r = await sendAndWait();
    assert.equal(r.ok, false, r.text);
    assert.match(r.text, /REFUSED/);
    const field = await page.getAttribute('#result', 'data-field');
    assert.match(field, /^p2/, r.text);
    assert.ok(await page.isVisible('#result .field.bad'));
    assert.equal(await page.getAttribute('#pick-list li:nth-child(2)', 'class'), 'bad');
    await page.screenshot({ path: path.join(artifacts, '02-width-refused.png') });
    say('width');
    await step('width');
    await clickAt(L.points.hinge_edge);
    await picks(1);
    await clickAt(L.points.moving_edge);
    await picks(2);
    r = await sendAndWait();
    assert.ok(r.ok, r.text);
    const width = Number(/width ([0-9.]+) m/.exec(r.text)[1]);
    assert.ok(Math.abs(width - truth.width) < 0.02, `width ${width} vs ${truth.width}`);
    assert.match(r.text, /opens CCW/);  // left hinge
    await waitState('awaiting_handle');

    say('handle');
    // 2. Handle: axis, then free end.
    await step('handle');
    await pickOn(L.points.handle_axis, 1);
    await pickOn(L.points.handle_free_end, 2);
    r = await sendAndWait();
    assert.ok(r.ok, r.text);
    const handle = Number(/handle length ([0-9.]+) m/.exec(r.text)[1]);
    assert.ok(Math.abs(handle - truth.handle) < 0.02, `handle ${handle} vs ${truth.handle}`);
    await waitState('awaiting_plane');

    say('plane');
    // 3. Plane: drag a rectangle on the door leaf (16 spread points).
    const plane = async () => {
      L = await landmarks();
      await step('plane');
      await dragRect({ u: L.points.leaf_low_left.u, v: L.points.leaf_high_middle.v },
        { u: L.points.leaf_low_right.u, v: L.points.leaf_low_left.v });
      await page.waitForFunction(() => document.querySelectorAll('#pick-list li').length >= 12);
      const res = await sendAndWait();
      assert.ok(res.ok, res.text);
      const yaw = Number(/yaw to square up ([-+0-9.]+) rad/.exec(res.text)[1]);
      assert.ok(Math.abs(yaw - L.truth.yaw_to_square_rad) < 0.02, `yaw ${yaw} vs truth ${L.truth.yaw_to_square_rad}`);
      return yaw;
    };
    const yaw0 = await plane();
    assert.ok(Math.abs(yaw0 - truth.yawDeg * Math.PI / 180) < 0.02);
    await waitState('ready_to_align');
    await page.screenshot({ path: path.join(artifacts, '03-plane.png') });

    say('estop mid-alignment');
    // 4a. EMERGENCY STOP mid-alignment (the Escape key): the fault latches.
    // The turn lasts under a second: the operator's Escape is pressed inside the page the moment the
    // daemon's motion_started event is shown (a round trip to the test process can be too slow on
    // a loaded machine). The key's binding itself is what is exercised.
    await page.evaluate(() => {
      const log = document.getElementById('log');
      const watch = new MutationObserver(() => {
        if (/motion_started/.test(log.textContent)) {
          watch.disconnect();
          window.dispatchEvent(new KeyboardEvent('keydown', { key: 'Escape', bubbles: true }));
        }
      });
      watch.observe(log, { childList: true });
    });
    await page.click('#btn-align');
    await page.waitForFunction(() => document.getElementById('fault').textContent === 'EMERGENCY_STOPPED');
    assert.ok(await page.$eval('#fault-box', (e) => e.classList.contains('latched')));
    // It stopped the turn: the motion was stopped, not finished.
    await page.waitForFunction(() => /motion_stopped/.test(document.getElementById('log').textContent));
    assert.ok(!/motion_finished/.test(await page.textContent('#log')), 'the alignment was interrupted');
    await page.screenshot({ path: path.join(artifacts, '04-estop-latched.png') });
    say('refused while latched');
    // Commands are refused while the fault is latched.
    await page.click('#btn-align');
    await page.waitForFunction(() => /refused/i.test(document.getElementById('log').textContent.split('\n').slice(-3).join(' ')) ||
      document.getElementById('command-result').dataset.ok === 'false');
    await page.click('#btn-reset');
    await page.waitForFunction(() => document.getElementById('fault').textContent === 'none');

    say('re-measure and align');
    // 4b. Re-measure the plane from where the base stopped, align, and see the door square.
    await until('a state that takes a plane', async () => ['awaiting_plane', 'ready_to_align'].includes(await page.textContent('#state')));
    await plane();
    await page.click('#btn-align');
    await waitState('aligned', 30000);
    L = await landmarks();
    const zl = L.points.hinge_edge.camera_m[2];
    const zr = L.points.moving_edge.camera_m[2];
    assert.ok(Math.abs(zl - zr) < 0.03, `after alignment the door edges are ${zl} and ${zr} m away`);
    assert.ok(Math.abs(L.truth.yaw_to_square_rad) < 0.03, `residual yaw ${L.truth.yaw_to_square_rad}`);
    await page.screenshot({ path: path.join(artifacts, '05-aligned.png') });

    say('contact and engage');
    // 5. Contact point on the handle, then Engage.
    await step('contact');
    await pickOn(L.points.contact, 1);
    r = await sendAndWait();
    assert.ok(r.ok, r.text);
    const c = /contact base \(([-0-9.]+), ([-0-9.]+), ([-0-9.]+)\)/.exec(r.text).slice(1).map(Number);
    const ct = L.points.contact.base_m;
    const err = Math.hypot(c[0] - ct[0], c[1] - ct[1], c[2] - ct[2]);
    assert.ok(err < 0.03, `contact ${c} vs truth ${ct}: ${err} m`);
    await waitState('ready_to_engage');
    await page.click('#btn-engage');
    await waitState('engaged', 60000);
    await page.screenshot({ path: path.join(artifacts, '06-engaged.png'), fullPage: true });

    say('close the page');
    // Closing the page stops feeding the deadman.
    await page.close();
    await until('the console to stop the heartbeat', async () => {
      const s = await (await fetch(url + 'api/state')).json();
      return s.connection.heartbeat === false;
    }, 5000);
  } catch (e) {
    console.error(`failed during: ${stage}`);
    if (page && !page.isClosed()) await page.screenshot({ path: path.join(artifacts, 'failure.png') }).catch(() => {});
    console.error('--- ajard ---\n' + ajard.output.slice(-3000));
    if (consoleProc) console.error('--- ajar-console ---\n' + consoleProc.output.slice(-3000));
    throw e;
  } finally {
    if (context) await context.close().catch(() => {});
    if (consoleProc) {
      consoleProc.kill('SIGINT');
      consoleStopped = await stopped(consoleProc, 5000);
      if (!consoleStopped) consoleProc.kill('SIGKILL');
    }
    ajard.kill('SIGTERM');
    await stopped(ajard, 5000);
    rmSync(work, { recursive: true, force: true });
  }
  assert.ok(consoleStopped, 'ajar-console stops on SIGINT (Ctrl-C)');
});

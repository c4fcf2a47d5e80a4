// The operator console in a real browser (Debian's headless Chromium, driven by playwright-core;
// no browser is downloaded): ajard on simulated hardware + ajar-console on the simulated camera.
//
// First the whole procedure by pointing at the image (values against the scenario's truth, an
// EMERGENCY STOP mid-alignment, the deadman), then one test per item of issue 23 ("never show the
// operator something that is no longer true"), each checked and screenshotted at 1280x720,
// 1920x1080 and 800x600. Item 5 (liveness) stops and kills processes: liveness.test.mjs.
//
// Run: scripts/test (stage "browser"), or: node --test tests/browser/
// Env: AJAR_BUILD_DIR (default build), AJAR_CHROMIUM (default /usr/bin/chromium).
// Screenshots: $AJAR_BUILD_DIR/browser-artifacts/*.png
import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { startStack, openPage, closeBrowser, until, scenarioNumber, axeViolations, dumpPages, VIEWPORTS } from './fixture.mjs';

let stack = null;
let failed = false;
before(async () => { stack = await startStack('console'); });
after(async () => { await closeBrowser(); if (stack) await stack.stop(failed); });
// Each test on the shared stack; the processes' output is printed when one fails.
// `body(P)` gets a fresh page at 1280x720; a failure leaves a screenshot and the page's log.
// A fault an earlier test left latched (it failed for it) is Reset first, saying so: each test
// fails for what it tests, not for the one before it.
function item(name, body, timeout = 60000) {
  test(name, { timeout }, async () => {
    const P = await openPage(stack);
    try {
      await P.page.waitForFunction(() => !['—', 'unknown'].includes(document.getElementById('state').textContent));  // ajard's status shown
      const left = await P.page.textContent('#fault');
      if (left !== 'none') {
        console.log(`# ${name}: an earlier test left ${left} latched: Reset first`);
        await P.page.click('#btn-reset');
        await P.page.waitForFunction(() => document.getElementById('fault').textContent === 'none');
      }
      await body(P);
    } catch (e) { failed = true; await dumpPages(name.replace(/\W+/g, '-').slice(0, 40)); throw e; } finally { await P.close(); }
  });
}

// Where the console drew each pick of `step` on the frame the page shows now.
const markers = (P, step) => P.page.evaluate((s) => (frameMeta && frameMeta.markers ? frameMeta.markers[s] : null), step);
// Hold a jog button for `ms` with a pointer of `pointerType` (mouse, touch, pen).
async function jog(P, dir, ms, pointerType = 'mouse') {
  const b = P.page.locator(`[data-jog=${dir}]`);
  await b.dispatchEvent('pointerdown', { pointerType, button: 0, isPrimary: true, bubbles: true });
  await P.page.waitForTimeout(ms);
  await b.dispatchEvent('pointerup', { pointerType, button: 0, isPrimary: true, bubbles: true });
}
const stillAgain = (P) => P.page.waitForFunction(() => lastTelemetry && !lastTelemetry.moving && document.getElementById('motion').textContent === '', null, { timeout: 15000 });
// With width and handle stored: a fresh plane and AlignBase, so the next test starts square to the door.
async function reSquare(P) {
  await P.planePicks(await stack.landmarks());
  const r = await P.send();
  assert.ok(r.ok, r.text);
  await P.page.click('#btn-align');
  await P.waitState('aligned', 30000);
  await stillAgain(P);
}
async function resetClear(P) {
  await P.page.click('#btn-reset-clear');
  await P.page.click('#confirm-ok');
  await P.waitState('awaiting_width');
}

item('the whole procedure by pointing at the simulated camera', async (P) => {
  const { page } = P;
  {
    assert.equal(await page.textContent('#role'), 'controller');
    assert.equal(await page.textContent('#state'), 'awaiting_width');
    await page.waitForFunction(() => document.getElementById('deadman-text').textContent === 'fed by this page');
    await P.shot('01-start');
    const truth = { width: scenarioNumber('width_m'), handle: scenarioNumber('length_m'), yawDeg: scenarioNumber('yaw_deg') };
    let L = await stack.landmarks();
    // Live data follows the cursor: camera frame and base frame (with the daemon's calibration).
    const q = await P.at(L.points.leaf_low_left);
    await page.mouse.move(q.x, q.y);
    await page.waitForFunction(() => /^[-+][0-9.]+$/.test(document.getElementById('live-bx').textContent));
    const cz = Number(await page.textContent('#live-cz'));
    assert.ok(Math.abs(cz - L.points.leaf_low_left.camera_m[2]) < 0.02, `hover depth ${cz}`);
    const bx = Number(await page.textContent('#live-bx'));
    const by = Number(await page.textContent('#live-by'));
    assert.ok(Math.hypot(bx - L.points.leaf_low_left.base_m[0], by - L.points.leaf_low_left.base_m[1]) < 0.03);

    // A refusal names its field and marks the pick: P1 and P2 on the same spot.
    await P.step('width');
    await P.clickAt(L.points.hinge_edge);
    await P.picks(1);
    await P.clickAt(L.points.hinge_edge);
    await P.picks(2);
    let r = await P.send();
    assert.equal(r.ok, false, r.text);
    assert.match(r.field, /^p2/, r.text);
    assert.ok(await page.isVisible('#result .field.bad'));
    assert.equal(await page.getAttribute('#pick-list li:nth-child(2)', 'class'), 'bad');
    await P.shot('02-width-refused');
    r = await P.width(L);
    assert.ok(r.ok, r.text);
    const width = Number(/width ([0-9.]+) m/.exec(r.text)[1]);
    assert.ok(Math.abs(width - truth.width) < 0.02, `width ${width} vs ${truth.width}`);
    assert.match(r.text, /opens CCW/);  // left hinge
    r = await P.handle(L);
    assert.ok(r.ok, r.text);
    const handle = Number(/handle length ([0-9.]+) m/.exec(r.text)[1]);
    assert.ok(Math.abs(handle - truth.handle) < 0.02, `handle ${handle} vs ${truth.handle}`);
    const plane = async () => {
      L = await stack.landmarks();
      await P.planePicks(L);
      const res = await P.send();
      assert.ok(res.ok, res.text);
      const yaw = Number(/yaw to square up ([-+0-9.]+) rad/.exec(res.text)[1]);
      assert.ok(Math.abs(yaw - L.truth.yaw_to_square_rad) < 0.02, `yaw ${yaw} vs truth ${L.truth.yaw_to_square_rad}`);
      return yaw;
    };
    const yaw0 = await plane();
    assert.ok(Math.abs(yaw0 - truth.yawDeg * Math.PI / 180) < 0.02);
    await P.waitState('ready_to_align');
    await P.shot('03-plane');

    // EMERGENCY STOP mid-alignment (Escape, pressed inside the page the moment the daemon says the
    // motion started: a round trip to the test process can be too slow on a loaded machine).
    await page.evaluate(() => {
      const log = document.getElementById('log');
      const watch = new MutationObserver(() => {
        if (/motion started/.test(log.textContent)) {
          watch.disconnect();
          window.dispatchEvent(new KeyboardEvent('keydown', { key: 'Escape', bubbles: true }));
        }
      });
      watch.observe(log, { childList: true });
    });
    await page.click('#btn-align');
    await page.waitForFunction(() => document.getElementById('fault').textContent === 'EMERGENCY_STOPPED');
    assert.ok(await page.$eval('#fault-box', (e) => e.classList.contains('latched')));
    await page.waitForFunction(() => /motion stopped/.test(document.getElementById('log').textContent));
    assert.ok(!/motion finished/.test(await page.textContent('#log')), 'the alignment was interrupted');
    await P.shot('04-estop-latched');
    await page.click('#btn-align');
    await page.waitForFunction(() => document.getElementById('command-result').dataset.ok === 'false');
    await page.click('#btn-reset');
    await page.waitForFunction(() => document.getElementById('fault').textContent === 'none');

    await until('a state that takes a plane', async () => ['awaiting_plane', 'ready_to_align'].includes(await page.textContent('#state')));
    await plane();
    await page.click('#btn-align');
    await P.waitState('aligned', 30000);
    L = await stack.landmarks();
    assert.ok(Math.abs(L.points.hinge_edge.camera_m[2] - L.points.moving_edge.camera_m[2]) < 0.03, 'door square after alignment');
    await P.shot('05-aligned');
    await P.step('contact');
    await P.pickOn(L.points.contact, 1);
    r = await P.send();
    assert.ok(r.ok, r.text);
    const c = /contact base \(([-0-9.]+), ([-0-9.]+), ([-0-9.]+)\)/.exec(r.text).slice(1).map(Number);
    const ct = L.points.contact.base_m;
    assert.ok(Math.hypot(c[0] - ct[0], c[1] - ct[1], c[2] - ct[2]) < 0.03, `contact ${c} vs truth ${ct}`);
    await P.waitState('ready_to_engage');
    await page.click('#btn-engage');
    await P.waitState('engaged', 60000);
    await P.shot('06-engaged');
    await resetClear(P);
  }
  // Closing the page stops feeding the deadman.
  await P.close();
  await until('the console to stop the heartbeat', async () => (await stack.apiState()).connection.heartbeat === false, 5000);
}, 150000);

item('issue 23 item 10: layout for gloves and small screens, a clean log, axe-core', async (P) => {
  const { page } = P;
  {
    const L = await stack.landmarks();
    const rects = async () => (await page.evaluate(() => window.scrollTo(0, 0))) || page.$$eval('button, input, #image, #result, #pick-list, #command-result', (els) =>
      els.filter((e) => e.offsetParent !== null).map((e) => { const r = e.getBoundingClientRect(); return `${e.id || e.dataset.step || e.dataset.jog}:${Math.round(r.x)},${Math.round(r.y)},${Math.round(r.width)},${Math.round(r.height)}`; }));
    await P.step('plane');
    const empty = {};
    for (const vp of VIEWPORTS) { await page.setViewportSize(vp); await page.waitForTimeout(100); empty[vp.name] = await rects(); }
    await page.setViewportSize(VIEWPORTS[0]);
    // Picks pile up, a refusal and a long result come in: nothing moves under the operator's finger.
    await P.planePicks(L);
    await P.step('width');
    await P.clickAt(L.points.hinge_edge);
    await P.clickAt(L.points.hinge_edge);
    await P.picks(2);
    const r = await P.send();
    assert.equal(r.ok, false);
    await page.click('#steps button[data-step=plane]');
    await page.waitForFunction(() => document.querySelectorAll('#pick-list li').length >= 12);
    await P.atEachViewport('item10-layout', async (vp) => {
      assert.deepEqual(await rects(), empty[vp.name], `no layout shift at ${vp.name}`);
      // No horizontal scrolling; the image keeps its aspect and grows with the window.
      assert.ok(await page.evaluate(() => document.documentElement.scrollWidth <= window.innerWidth), `no horizontal scroll at ${vp.name}`);
      const box = await P.box();
      assert.ok(Math.abs(box.width / box.height - 4 / 3) < 0.01, `aspect ${box.width}x${box.height}`);
      if (vp.width === 1920) assert.ok(box.width > 900, `the image scales: ${box.width} px wide at 1920`);
      // The key state above the fold: state, fault, door distance, E-STOP, STOP, the image's messages.
      for (const sel of ['#state-box', '#fault-box', '#estop', '#btn-stop-top', '#hud-door', '#live-badge', '#canvas-wrap']) {
        assert.ok(await P.inViewport(sel), `${sel} above the fold at ${vp.name}`);
      }
      // The daemon's refusal, on the image.
      assert.match(await page.textContent('#image-msg'), /REFUSED/);
      assert.ok(await P.inViewport('#image-msg'), `the refusal above the fold at ${vp.name}`);
      if (vp.width >= 1280) {
        for (const sel of ['#btn-stop', '#btn-send', '#btn-align']) assert.ok(await P.inViewport(sel), `${sel} above the fold at ${vp.name}`);
      }
      // Targets for gloves: at least 48 x 48 px.
      const small = await page.$$eval('button, input, [tabindex]', (els) => els.filter((e) => e.offsetParent !== null)
        .map((e) => { const r = e.getBoundingClientRect(); return { id: e.id || e.textContent.trim().slice(0, 12), w: r.width, h: r.height }; })
        .filter((t) => t.w < 47.5 || t.h < 47.5));
      assert.deepEqual(small, [], `targets under 48 px at ${vp.name}`);
      assert.deepEqual(await axeViolations(page), [], `axe-core at ${vp.name}`);
    });
    // "Reset & clear" asks first, and Cancel changes nothing.
    const mark = await P.logMark();
    await page.click('#btn-reset-clear');
    assert.ok(await page.isVisible('#confirm-clear'));
    await P.shot('item10-confirm-clear');
    await page.click('#confirm-cancel');
    await page.waitForTimeout(300);
    assert.ok(!(await P.logSince(mark)).some((l) => /Reset/.test(l)), 'no Reset sent before the confirmation');
    assert.ok((await page.$$eval('#pick-list li', (l) => l.length)) >= 12, 'picks kept');
    // Jog buttons answer touch: held -> the base drives; released -> it stops.
    const m2 = await P.logMark();
    await jog(P, 'back', 400, 'touch');
    await until('a jog from touch', async () => (await P.logSince(m2)).some((l) => /motion started: driving/.test(l)));
    await until('the jog to end', async () => (await P.logSince(m2)).some((l) => /motion finished: driving ended/.test(l)));
    await stillAgain(P);
    // A clean event log: an emergency stop reads "FAULT LATCHED: EMERGENCY_STOPPED", never "fault fault".
    await page.click('#estop');
    await page.waitForFunction(() => document.getElementById('fault').textContent === 'EMERGENCY_STOPPED');
    const log = await page.textContent('#log');
    assert.match(log, /FAULT LATCHED: EMERGENCY_STOPPED/);
    assert.doesNotMatch(log, /fault fault|event \w+:/);
    await page.click('#btn-reset');
    await page.waitForFunction(() => document.getElementById('fault').textContent === 'none');
    await resetClear(P);
  }
});

item('issue 23 item 8: P1/P2 reversed is caught by the handle\'s side', async (P) => {
  const { page } = P;
  {
    const L = await stack.landmarks();
    let r = await P.width(L, { reversed: true });
    assert.ok(r.ok, r.text);  // the daemon cannot know: it answers "opens CW"
    assert.match(r.text, /opens CW/);
    r = await P.handle(L);
    assert.equal(r.ok, false, r.text);
    assert.match(r.text, /NOT SENT/);
    assert.match(r.text, /P1 and P2 look reversed/);
    assert.equal(await page.textContent('#state'), 'awaiting_handle');
    await P.atEachViewport('item8-reversed', async () => {
      assert.ok(await page.isVisible('#result.refused'));
    });
    // The width step says it too.
    await page.click('#steps button[data-step=width]');
    await page.waitForFunction(() => document.getElementById('result').dataset.warning === 'hinge');
    // Measured the right way round, the handle is accepted.
    r = await P.width(L);
    assert.ok(r.ok && /opens CCW/.test(r.text), r.text);
    r = await P.handle(L);
    assert.ok(r.ok, r.text);
    await resetClear(P);
  }
});

item('issue 23 item 9: status that is no longer true is not shown', async (P) => {
  const { page } = P;
  {
    const L = await stack.landmarks();
    assert.ok((await P.width(L)).ok);
    // The command box says what was done and when, never a state that has passed.
    await page.click('#btn-reset');
    await page.waitForFunction(() => document.getElementById('command-result').dataset.op === 'reset');
    assert.doesNotMatch(await page.textContent('#command-result'), /awaiting_|ready_to|→/);
    assert.ok((await P.handle(L)).ok);
    await P.planePicks(L);
    assert.ok((await P.send()).ok);
    await page.waitForFunction(() => document.querySelector('#steps button[data-step=plane]').classList.contains('stored'));
    // Live data: gone once the cursor leaves the image.
    const q = await P.at(L.points.leaf_low_left);
    await page.mouse.move(q.x, q.y);
    await page.waitForFunction(() => document.getElementById('live-cz').textContent !== '—');
    await page.mouse.move(5, 400);
    await page.waitForFunction(() => document.getElementById('live-cz').textContent === '—');
    // While the base jogs the header says so; once it has moved beyond the staleness rule the plane
    // step says STALE, not ✓.
    const m = await P.logMark();
    const b = page.locator('[data-jog=back]');
    await b.dispatchEvent('pointerdown', { pointerType: 'mouse', button: 0, isPrimary: true });
    await page.waitForFunction(() => /JOGGING/.test(document.getElementById('motion').textContent));
    await P.atEachViewport('item9-jogging', async () => {
      assert.match(await page.textContent('#state-box'), /JOGGING/);
      assert.ok(await P.inViewport('#hud-motion'));
    });
    await page.waitForFunction(() => lastTelemetry && lastTelemetry.staleness && lastTelemetry.staleness.plane, null, { timeout: 10000 });
    await b.dispatchEvent('pointerup', { pointerType: 'mouse', button: 0, isPrimary: true });
    await stillAgain(P);
    assert.ok((await P.logSince(m)).some((l) => /motion finished/.test(l)));
    await page.click('#steps button[data-step=plane]');
    await page.waitForFunction(() => document.querySelector('#steps button[data-step=plane]').classList.contains('stale'));
    await P.atEachViewport('item9-plane-stale', async () => {
      assert.match(await page.textContent('#steps button[data-step=plane]'), /STALE/);
      assert.doesNotMatch(await page.textContent('#steps button[data-step=plane]'), /✓/);
      assert.match(await page.textContent('#hud-warn'), /PLANE STALE/);
      assert.ok(await P.inViewport('#hud-warn'));
    });
    await resetClear(P);
  }
});

item('issue 23 items 1 and 2: picks know their pose: markers follow the base; old picks are transformed or refused', async (P) => {
  const { page } = P;
  {
    let L = await stack.landmarks();
    assert.ok((await P.width(L)).ok);
    assert.ok((await P.handle(L)).ok);
    // Handle picks on the image, then a short jog: the markers move with the handle (item 2).
    await P.step('handle');
    await P.pickOn(L.points.handle_axis, 1);
    await P.pickOn(L.points.handle_free_end, 2);
    await P.planePicks(L);
    const m = await P.logMark();
    await jog(P, 'left', 150);
    await until('the jog', async () => (await P.logSince(m)).some((l) => /motion started/.test(l)));
    await stillAgain(P);
    await page.waitForTimeout(300);  // a frame rendered at the pose where the base stopped
    L = await stack.landmarks();
    await page.click('#steps button[data-step=handle]');
    const mk = await until('markers for the frame', async () => {
      const k = await markers(P, 'handle');
      return k && k.length === 2 && k;
    });
    const travel = await page.evaluate(() => state.picks.handle[0].moved || '');
    assert.notEqual(mk[0].place, 'here', `the base moved: ${travel}`);
    if (mk[0].place === 'moved') {
      const err = Math.hypot(mk[0].u - L.points.handle_axis.u, mk[0].v - L.points.handle_axis.v);
      assert.ok(err < 6, `handle axis marker at (${mk[0].u}, ${mk[0].v}), the handle is at (${L.points.handle_axis.u}, ${L.points.handle_axis.v})`);
    }
    await P.atEachViewport('item2-markers-moved', async () => {
      assert.match(await page.textContent('#pick-list'), /moved: the base moved|STALE/);
    });
    // The plane picks from before the jog: sent transformed (and the page says so) within the
    // daemon's staleness rule, refused beyond it: the page and the daemon agree (item 1).
    await page.click('#steps button[data-step=plane]');
    const moved = await page.evaluate(() => state.picks.plane[0]);
    const r = await P.send();
    if (moved.place === 'moved') {
      assert.ok(r.ok, r.text);
      assert.match(r.text, /transformed by odometry: the base moved [0-9.]+ m \/ [0-9.]+° since/);
      const yaw = Number(/yaw to square up ([-+0-9.]+) rad/.exec(r.text)[1]);
      assert.ok(Math.abs(yaw - L.truth.yaw_to_square_rad) < 0.02, `yaw ${yaw} vs truth now ${L.truth.yaw_to_square_rad}`);
    } else {
      assert.equal(moved.place, 'stale');
      assert.equal(r.ok, false);
      assert.match(r.text, /pick again: the base moved [0-9.]+ m \/ [0-9.]+° since/);
    }
    await P.shot('item1-sent-after-jog');
    // New picks, then a turn beyond the daemon's staleness rule (drive.stale_yaw_rad = 0.05 rad):
    // the picks are stale — greyed on the image — and Send refuses them instead of re-sending them;
    // the daemon says the same of its plane (item 1).
    await P.planePicks(L);
    const m2 = await P.logMark();
    await jog(P, 'left', 700);
    await until('the turn', async () => (await P.logSince(m2)).some((l) => /motion started/.test(l)));
    await stillAgain(P);
    const turned = await page.evaluate(() => state.picks.plane[0]);
    const grey = await until('stale markers', async () => { const k = await markers(P, 'plane'); return k && k.length && k.every((x) => x.place === 'stale' || x.place === 'out') && k; });
    assert.ok(grey.length >= 12, `${grey.length} markers; ${turned.moved}`);
    const m3 = await P.logMark();
    const r2 = await P.send();
    assert.equal(r2.ok, false, r2.text);
    assert.match(r2.text, /pick again: the base moved [0-9.]+ m \/ [0-9.]+° since/);
    assert.ok(!(await P.logSince(m3)).some((l) => /sending MeasureDoorPlane/.test(l)), 'nothing sent');
    assert.ok(await page.evaluate(() => lastTelemetry.staleness.plane), 'the daemon calls its plane (sent from the same pose) stale too');
    await P.atEachViewport('item1-stale-refused', async () => {
      assert.ok(await page.isVisible('#result.refused'));
      assert.match(await page.textContent('#pick-list'), /STALE/);
    });
    await reSquare(P);
    await resetClear(P);
  }
}, 90000);

item('issue 23 item 4: the role follows the daemon: take-over by ajarctl shows within 1 s', async (P) => {
  const { page } = P;
  {
    assert.equal(await page.textContent('#role'), 'controller');
    const r = await stack.ajarctl(['--take-over', 'reset']);
    assert.equal(r.code, 0, r.output);
    const t0 = Date.now();
    await page.waitForFunction(() => document.getElementById('role').textContent === 'observer', null, { timeout: 1000 });
    assert.ok(Date.now() - t0 <= 1000);
    await P.atEachViewport('item4-observer', async () => {
      assert.ok(await P.inViewport('#btn-take-over'), 'Take over in view');
      assert.ok(!(await page.isVisible('#deadman')), 'Take over where the deadman was');
      assert.ok(await page.isDisabled('#btn-align'));
    });
    // A reload shows the same (the console keeps the role the daemon gave it).
    await page.reload();
    await page.waitForFunction(() => document.getElementById('role').textContent === 'observer');
    await page.click('#btn-take-over');
    await page.waitForFunction(() => document.getElementById('role').textContent === 'controller', null, { timeout: 10000 });
    await page.waitForFunction(() => document.getElementById('deadman-text').textContent === 'fed by this page');
    assert.ok(!(await page.isDisabled('#btn-align')));
  }
});

item('issue 23 item 3: Space stops and Escape e-stops whatever has focus; arrows jog only on the image or pad', async (P) => {
  const { page } = P;
  {
    const L = await stack.landmarks();
    assert.ok((await P.width(L)).ok);
    assert.ok((await P.handle(L)).ok);
    // Turned off square first (the earlier tests may have left the base square to the door).
    await jog(P, 'left', 700);
    await page.waitForFunction(() => lastTelemetry && lastTelemetry.moving);
    await stillAgain(P);
    await P.planePicks(await stack.landmarks());
    assert.ok((await P.send()).ok);
    // Click "Align base" (it keeps the focus) and press Space: the turn stops, no second AlignBase.
    const m = await P.logMark();
    await page.click('#btn-align');
    await page.keyboard.press(' ');
    await until('the stop', async () => (await P.logSince(m)).some((l) => /motion stopped/.test(l)));
    const lines = await P.logSince(m);
    assert.equal(lines.filter((l) => /sending AlignBase/.test(l)).length, 1, lines.join('\n'));
    assert.ok(lines.some((l) => /sending Stop/.test(l)) && lines.some((l) => /stop: accepted/.test(l)), lines.join('\n'));
    assert.ok(!lines.some((l) => /motion finished/.test(l)), 'the turn did not finish');
    await stillAgain(P);
    await P.atEachViewport('item3-keys', async (vp) => {
      // In the text field: Space is Stop (not a character), arrows change nothing and do not jog.
      await page.fill('#standoff', '0.90');
      await page.focus('#standoff');
      const k = await P.logMark();
      await page.keyboard.press(' ');
      await page.keyboard.down('ArrowUp'); await page.waitForTimeout(250); await page.keyboard.up('ArrowUp');
      await until('Stop from the field', async () => (await P.logSince(k)).some((l) => /stop: accepted/.test(l)));
      assert.equal(await page.inputValue('#standoff'), '0.90', `the field is unchanged at ${vp.name}`);
      // A focused button: arrows neither jog nor press it.
      await page.focus('#btn-undo');
      await page.keyboard.down('ArrowUp'); await page.waitForTimeout(250); await page.keyboard.up('ArrowUp');
      await page.waitForTimeout(200);
      assert.ok(!(await P.logSince(k)).some((l) => /driving|sending Drive/.test(l)), (await P.logSince(k)).join('\n'));
    });
    // On the image, a held arrow jogs and its release stops.
    const j = await P.logMark();
    await page.focus('#image');
    await page.keyboard.down('ArrowDown'); await page.waitForTimeout(300); await page.keyboard.up('ArrowDown');
    await until('a jog from the arrow key', async () => (await P.logSince(j)).some((l) => /motion started: driving/.test(l)));
    await until('the jog to end', async () => (await P.logSince(j)).some((l) => /motion finished/.test(l)));
    await stillAgain(P);
    // Escape in the text field: EMERGENCY STOP.
    await page.focus('#standoff');
    await page.keyboard.press('Escape');
    await page.waitForFunction(() => document.getElementById('fault').textContent === 'EMERGENCY_STOPPED');
    await page.click('#btn-reset');
    await page.waitForFunction(() => document.getElementById('fault').textContent === 'none');
    await reSquare(P);
    await resetClear(P);
  }
});

item('issue 23 item 7: the default standoff keeps the handle and both edges in view', async (P) => {
  const { page } = P;
  {
    const L = await stack.landmarks();
    assert.ok((await P.width(L)).ok);
    assert.ok((await P.handle(L)).ok);
    await P.planePicks(L);
    assert.ok((await P.send()).ok);
    // Square to the door first (Approach drives straight).
    await page.click('#btn-align');
    await P.waitState('aligned', 30000);
    await stillAgain(P);
    await page.waitForFunction(() => state.guidance && state.guidance.default_standoff_m !== undefined);
    const def = await page.evaluate(() => state.guidance.default_standoff_m);
    assert.equal(Number(await page.inputValue('#standoff')), Number(def.toFixed(2)), 'the field shows the default');
    // The paper's 0.75 m: the page warns which landmark leaves the view.
    await page.fill('#standoff', '0.60');
    await page.waitForFunction(() => Number(document.getElementById('guidance').dataset.warnings) > 0);
    await P.atEachViewport('item7-warn', async () => {
      assert.match(await page.textContent('#guidance'), /at 0\.60 m the .* (leaves the image|closer than)/);
    });
    await page.fill('#standoff', def.toFixed(2));
    await page.click('#btn-approach');
    await page.waitForFunction(() => /APPROACHING/.test(document.getElementById('motion').textContent), null, { timeout: 5000 });
    await P.shot('item7-approaching');
    await until('the approach to end', async () => /motion finished|motion stopped/.test(await page.textContent('#log')), 20000);
    await stillAgain(P);
    await page.waitForTimeout(300);
    const after = await stack.landmarks();
    for (const name of ['hinge_edge', 'moving_edge', 'handle_axis', 'handle_free_end']) {
      const p = after.points[name];
      assert.ok(p.u > 0 && p.u < 639 && p.v > 0 && p.v < 479, `${name} in view at the default standoff ${def}: ${JSON.stringify(p)}`);
    }
    await P.atEachViewport('item7-at-default', async () => {
      assert.match(await page.textContent('#hud-door'), /door [0-9.]+ m/);
    });
    await resetClear(P);
  }
});

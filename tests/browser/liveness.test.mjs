// Issue 23 item 5: the liveness indicators never lie. Its own ajard + ajar-console, stopped
// (SIGSTOP) and killed in turn: the page says FROZEN within 1 s and greys the image, refuses picks
// on it, and without a link the EMERGENCY STOP says "NO LINK — use the robot's hardware e-stop"
// (a click says it was not sent) while the page keeps retrying; a console started again on the
// same address is found again.
import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import path from 'node:path';
import { startStack, openPage, closeBrowser, dumpPages, until, stopped, build, scenarioPath } from './fixture.mjs';

after(closeBrowser);

test('issue 23 item 5: FROZEN within 1 s when the console or ajard stops; NO LINK when the console is gone', { timeout: 90000 }, async () => {
  const stack = await startStack('liveness');
  let failed = true;
  let P = null;
  let restarted = null;
  try {
    P = await openPage(stack);
    const { page } = P;
    const L = await stack.landmarks();
    const frozenWithin = async (what, ms) => {
      const t0 = Date.now();
      await page.waitForFunction(() => document.getElementById('live-badge').dataset.state === 'frozen', null, { timeout: ms });
      return Date.now() - t0;
    };
    const atEach = (name, check) => P.atEachViewport(name, check);

    // The header's pills are never cut off: live, and with the longest values they can hold.
    const widest = { state: 'ready_to_engage', motion: '· APPROACHING', fault: 'CARD_COMMUNICATION', role: 'controller' };
    await atEach('item5-live', async (vp) => {
      assert.deepEqual(await P.truncatedPills(), [], `live at ${vp.name}`);
      assert.deepEqual(await P.truncatedPills(widest), [], `the widest values at ${vp.name}`);
      assert.equal(await page.isDisabled('#btn-align'), false, 'a controller that ajard answers may command');
    });

    // ajard stops (SIGSTOP): the camera still renders, but the daemon's telemetry is frozen.
    process.kill(stack.ajard.pid, 'SIGSTOP');
    assert.ok(await frozenWithin('ajard', 1000) <= 1000);
    await page.waitForFunction(() => /no telemetry from ajard/.test(document.getElementById('live-badge').textContent));
    assert.ok(await page.$eval('#image', (e) => e.classList.contains('frozen')), 'the image is greyed');
    await page.waitForFunction(() => document.getElementById('estop').dataset.link === 'down');
    // A pick on the frozen image is refused; nothing is added.
    await P.clickAt(L.points.leaf_low_left);
    await page.waitForFunction(() => /FROZEN/.test(document.getElementById('image-msg').textContent));
    assert.equal(await page.$$eval('#pick-list li', (l) => l.length), 0);
    await atEach('item5-ajard-frozen', async (vp) => {
      assert.match(await page.textContent('#live-badge'), /^FROZEN [0-9.]+ m?s — no telemetry from ajard/);
      assert.match(await page.textContent('#estop'), /NO LINK — use the robot’s hardware e-stop/);
      assert.ok(await P.inViewport('#live-badge'));
      // Nothing ajard said is shown as current: not the state, the fault, the deadman, the door.
      assert.equal(await page.textContent('#conn-text'), 'ajard not answering');
      assert.equal(await page.textContent('#state'), 'unknown');
      assert.equal(await page.textContent('#fault'), 'unknown');
      assert.match(await page.textContent('#deadman-text'), /unknown/);
      assert.match(await page.textContent('#hud-door'), /unknown/);
      assert.equal(await page.textContent('#role'), 'unknown', 'the role ajard gave is not shown as current');
      assert.deepEqual(await P.truncatedPills(), [], `frozen at ${vp.name}`);
      // Nothing can be commanded while ajard is silent (it would act later on a state nobody sees);
      // STOP and EMERGENCY STOP can always be pressed.
      for (const id of ['#btn-align', '#btn-engage', '#btn-send', '#btn-approach', '#btn-reset', '[data-jog="fwd"]']) {
        assert.equal(await page.isDisabled(id), true, `${id} disabled while ajard is not answering`);
      }
      assert.equal(await page.isDisabled('#btn-stop-top'), false);
      assert.equal(await page.isDisabled('#estop'), false);
    });
    process.kill(stack.ajard.pid, 'SIGCONT');
    await page.waitForFunction(() => document.getElementById('live-badge').dataset.state === 'live', null, { timeout: 10000 });
    assert.match(await page.textContent('#live-badge'), /^LIVE [0-9]+ ms$/);
    assert.equal(await page.getAttribute('#estop', 'data-link'), 'up');

    // The console stops (SIGSTOP): nothing arrives at all.
    process.kill(stack.console.pid, 'SIGSTOP');
    assert.ok(await frozenWithin('console', 1000) <= 1000);
    await page.waitForFunction(() => document.getElementById('estop').dataset.link === 'down', null, { timeout: 2000 });
    await page.waitForFunction(() => /console not answering/.test(document.getElementById('conn-text').textContent), null, { timeout: 2000 });
    await atEach('item5-console-frozen', async () => {
      assert.match(await page.textContent('#live-badge'), /^FROZEN/);
      assert.match(await page.textContent('#conn-text'), /console not answering/);
      assert.match(await page.textContent('#estop'), /NO LINK/);
    });
    process.kill(stack.console.pid, 'SIGCONT');
    await page.waitForFunction(() => document.getElementById('live-badge').dataset.state === 'live', null, { timeout: 10000 });

    // The console is killed: NO LINK, the deadman is not fed, a click on the E-STOP says it was
    // not sent. The page keeps retrying: a console started again on the same address is found.
    const consoleUrl = new URL(stack.url);
    stack.console.kill('SIGKILL');
    await stopped(stack.console, 5000);
    await page.waitForFunction(() => document.getElementById('estop').dataset.link === 'down', null, { timeout: 2000 });
    await page.click('#estop');
    await page.waitForFunction(() => /EMERGENCY STOP: NO LINK.*not sent.*hardware e-stop/.test(document.getElementById('image-msg').textContent));
    await atEach('item5-console-killed', async (vp) => {
      assert.match(await page.textContent('#estop'), /NO LINK — use the robot’s hardware e-stop/);
      assert.deepEqual(await P.truncatedPills(), [], `no link at ${vp.name}`);
      assert.match(await page.textContent('#deadman-text'), /NOT fed/);
      assert.match(await page.textContent('#conn-text'), /console unreachable/);
      assert.match(await page.textContent('#live-badge'), /^FROZEN/);
      assert.ok(await P.inViewport('#estop'));
    });
    restarted = spawn(path.join(build, 'console/ajar-console'), ['--connect', `127.0.0.1:${stack.daemonPort}`,
      '--listen', `127.0.0.1:${consoleUrl.port}`, '--scenario', scenarioPath], { stdio: 'ignore' });
    await page.waitForFunction(() => document.getElementById('live-badge').dataset.state === 'live', null, { timeout: 15000 });
    await page.waitForFunction(() => document.getElementById('estop').dataset.link === 'up');
    await until('the deadman fed again', async () => /fed by this page/.test(await page.textContent('#deadman-text')));
    failed = false;
  } finally {
    if (failed) await dumpPages('item5');
    if (P) await P.close();
    if (restarted) { restarted.kill('SIGINT'); if (!await stopped(restarted, 5000)) restarted.kill('SIGKILL'); }
    await stack.stop(failed);
  }
});

// The page's black-box panel (docs/console.md, "The black box"): the recorder's state as ajard
// reports it and "Save the last 5 minutes", by keyboard, with the daemon's answer shown — a saved
// recording's name, or a refusal with the field it names — and axe-core clean.
//
// A refusal is shown with the field it names (REQUEST_OUT_OF_RANGE on last_s). Against an ajard
// whose black box is off (recorder.enabled: false): the panel says OFF with the daemon's reason,
// and Save shows its refusal (NOT_SUPPORTED). A tree whose ajard or
// console does not speak the black box yet (protocol 1.2) shows "unknown" with the reason and a
// refusal naming it: never a state ajard did not report.
//
// Run: scripts/test (stage "browser"), or: node --test tests/browser/
import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import path from 'node:path';
import { withStack, openPage, closeBrowser, axeViolations, dumpPages, artifacts } from './fixture.mjs';

after(async () => { await closeBrowser(); });

// Focus Save with the keyboard (Tab from the button before it in the page order) and press Enter.
async function saveByKeyboard(P) {
  const { page } = P;
  await page.evaluate(() => { const el = document.getElementById('recorder-result'); el.dataset.ok = ''; el.textContent = ''; });
  await page.focus('#plots-region canvas:last-of-type').catch(() => {});
  await page.focus('#btn-save-recording');
  assert.equal(await page.evaluate(() => document.activeElement.id), 'btn-save-recording', 'Save takes the keyboard focus');
  await page.keyboard.press('Enter');
  await page.waitForFunction(() => ['true', 'false'].includes(document.getElementById('recorder-result').dataset.ok), null, { timeout: 15000 });
  return {
    ok: (await page.getAttribute('#recorder-result', 'data-ok')) === 'true',
    text: await page.textContent('#recorder-result'),
    code: await page.getAttribute('#recorder-result', 'data-code'),
    field: await page.getAttribute('#recorder-result', 'data-field'),
  };
}
const panel = async (P) => ({
  on: await P.page.textContent('#rec-on'),
  state: await P.page.getAttribute('#rec-on', 'data-state'),
  file: await P.page.textContent('#rec-file'),
  size: await P.page.textContent('#rec-size'),
  drops: await P.page.textContent('#rec-drops'),
  dropCount: Number(await P.page.getAttribute('#rec-drops', 'data-count')),
  written: Number(await P.page.getAttribute('#rec-written', 'data-count')),
});
// Status.recorder as ajarctl reads it from the same ajard (protocol 1.2), independently of the console.
async function ajardRecorder(stack) {
  const { code, output } = await stack.ajarctl(['--json', 'status']);
  assert.equal(code, 0, output);
  const line = output.split('\n').find((l) => l.startsWith('{') && l.includes('"status"'));
  const r = JSON.parse(line).status.recorder;
  assert.ok(r, `ajarctl status --json has a recorder: ${line}`);
  return { ...r, drops: r.loop_dropped + r.io_dropped };
}

test('black box panel: the recorder\'s state and "Save the last 5 minutes" with the daemon\'s answer', { timeout: 90000 }, async () => {
  await withStack('recorder-panel', async (stack) => {
    const P = await openPage(stack);
    try {
      const { page } = P;
      // The console asks ajard every 2 s: the panel shows its word, or why there is none.
      await page.waitForFunction(() => document.getElementById('rec-on').dataset.state !== undefined &&
        !/has not asked/.test(document.getElementById('rec-on').textContent), null, { timeout: 15000 });
      // The page draws every state message before any command was sent (it threw on the null
      // last_command in showRefusalsOnImage and left the rest of the state undrawn).
      assert.deepEqual(P.errors.map(String), [], 'no script error before the first command');
      const api = await stack.apiState();
      const before = await panel(P);
      if (!api.recorder.known) {
        // No 1.2 black box in this tree: "unknown" everywhere, the reason said, Save refused saying it.
        assert.equal(before.state, 'unknown');
        assert.match(before.on, new RegExp(`unknown \\(${api.recorder.why.replace(/[()]/g, '.')}\\)`));
        assert.deepEqual([before.file, before.size, before.drops], ['unknown', 'unknown', 'unknown']);
        const r = await saveByKeyboard(P);
        assert.equal(r.ok, false);
        assert.equal(r.code, 'NOT_SUPPORTED');
        assert.match(r.text, /black box|protocol/);
      } else {
        // ajard records (the shipped simulated config): ON, the file being written, its size.
        assert.equal(before.state, 'on', JSON.stringify(api.recorder));
        assert.ok(before.file.length > 3 && before.file !== '—', before.file);
        assert.match(before.size, /\d+(\.\d)? (B|KiB|MiB|GiB)/);
        // Drops and records written are Status.recorder's: bracketed by two reads of ajard's Status
        // (ajarctl), the panel's numbers between them (they only grow), the file the same.
        const a = await ajardRecorder(stack);
        await page.waitForFunction((w) => Number(document.getElementById('rec-written').dataset.count) >= w,
          a.records_written, { timeout: 15000 });
        const p = await panel(P);
        const b = await ajardRecorder(stack);
        assert.equal(a.mode, 'recording');
        assert.ok(a.records_written <= p.written && p.written <= b.records_written, JSON.stringify({ a, p, b }));
        assert.ok(a.drops <= p.dropCount && p.dropCount <= b.drops, JSON.stringify({ a, p, b }));
        assert.match(p.drops, new RegExp(`^${p.dropCount} \\(loop \\d+ of \\d+, I/O \\d+ of \\d+\\)$`));
        assert.equal(p.file, b.file);
        assert.ok(p.written > 0, 'the recorder writes');
        const r = await saveByKeyboard(P);
        assert.equal(r.ok, true, r.text);
        assert.match(r.text, /saved at \d\d:\d\d:\d\d: [1-9]\d* recordings? — \S+/);
        const log = await page.textContent('#log');
        assert.match(log, /black box: save: \{"ok":true/);
        // A refusal is shown with the field it names, highlighted (a page asking for -1 s).
        await page.evaluate(() => { document.getElementById('recorder-result').dataset.ok = ''; send({ op: 'save_recording', last_s: -1 }); });
        await page.waitForFunction(() => document.getElementById('recorder-result').dataset.ok === 'false');
        assert.equal(await page.getAttribute('#recorder-result', 'data-code'), 'REQUEST_OUT_OF_RANGE');
        assert.equal(await page.textContent('#recorder-result .field.bad'), 'last_s');
        assert.match(await page.textContent('#recorder-result'), /last_s is -1/);
      }
      await page.locator('#recorder-region').screenshot({ path: path.join(artifacts, 'recorder-panel.png') });
      assert.deepEqual(await axeViolations(page), []);
      assert.deepEqual(P.errors, []);
    } catch (e) {
      await dumpPages('recorder-panel');
      throw e;
    } finally {
      await P.close();
    }
  });
});

test('black box panel: an ajard with its black box off says so, and Save shows the refusal with its field', { timeout: 90000 }, async () => {
  await withStack('recorder-panel-off', async (stack) => {
    const P = await openPage(stack);
    try {
      const { page } = P;
      await page.waitForFunction(() => !/has not asked/.test(document.getElementById('rec-on').textContent), null, { timeout: 15000 });
      const api = await stack.apiState();
      const r = await saveByKeyboard(P);
      assert.equal(r.ok, false);
      assert.equal(r.code, 'NOT_SUPPORTED');
      if (api.recorder.known) {
        assert.equal(await page.getAttribute('#rec-on', 'data-state'), 'off');
        assert.match(await page.textContent('#rec-on'), /^OFF \(.*recorder is off.*\)/);
        assert.match(r.text, /recorder is off/);
        assert.deepEqual([await page.textContent('#rec-file'), await page.textContent('#rec-size')], ['—', '—']);
      }
      assert.deepEqual(await axeViolations(page), []);
    } catch (e) {
      await dumpPages('recorder-panel-off');
      throw e;
    } finally {
      await P.close();
    }
  }, { ajardConfig: (yaml) => yaml.replace(/^(recorder:[^\n]*\n\s+enabled:\s*)true/m, '$1false') });
});

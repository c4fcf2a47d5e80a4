// The black box (docs/blackbox.md) read back by an independent reader: @mcap/core (npm, the MCAP
// project's own TypeScript library) and ajv (JSON Schema 2020-12).
//
// ajard on simulated hardware records while `ajarctl simulate` runs the whole procedure; after a
// clean stop its recording must be a complete MCAP file: every record valid (@mcap/core's stream
// reader to the trailing magic, its indexed reader over the summary), the data section's CRC and the
// summary's as the specification defines them, every channel's schema a valid JSON Schema and every
// JSON message valid against it, every /ajar/wire message a whole protocol frame, and the message
// counts equal to what the daemon says it recorded (its Statistics record and its last
// /ajar/recorder counters). A copy cut at a random byte (a simulated kill -9; the seed is printed,
// AJAR_SEED=... replays it) still yields every message before the cut. Then a real kill -9 of a
// recording ajard: the file reads up to its last whole record; the test prints what was lost.
//
// Run: scripts/test (stage "browser"), or: node --test tests/browser/blackbox.test.mjs
// Env: AJAR_BUILD_DIR (default build).
import { test, after } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import { mkdtempSync, readFileSync, writeFileSync, readdirSync, existsSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { McapStreamReader, McapIndexedReader } from '@mcap/core';
import { crc32 } from '@foxglove/crc';
import Ajv2020 from 'ajv/dist/2020.js';

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const build = path.resolve(root, process.env.AJAR_BUILD_DIR || 'build');
const ajardPath = path.join(build, 'daemon/ajard');
const ajarctlPath = path.join(build, 'client/ajarctl');

function start(cmd, args) {
  const child = spawn(cmd, args, { stdio: ['ignore', 'pipe', 'pipe'] });
  child.output = '';
  child.stdout.on('data', (d) => { child.output += d; });
  child.stderr.on('data', (d) => { child.output += d; });
  child.exited = new Promise((resolve) => child.on('exit', (code, signal) => resolve({ code, signal })));
  return child;
}
async function until(what, fn, timeoutMs = 20000) {
  const end = Date.now() + timeoutMs;
  for (;;) {
    const v = await fn();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out waiting for ${what}`);
    await new Promise((r) => setTimeout(r, 50));
  }
}

// ajard on config/ajard.yaml with its state and recordings in `work`.
async function startAjard(work) {
  const config = path.join(work, 'ajard.yaml');
  const text = readFileSync(path.join(root, 'config/ajard.yaml'), 'utf8')
    .replace(/^(\s*directory:\s*)build\/recordings\s*$/m, `$1${path.join(work, 'recordings')}`);
  assert.match(text, new RegExp(`directory: ${path.join(work, 'recordings')}`), 'the shipped config records');
  assert.match(text, /^recorder:.*\n\s+enabled: true/m, "recording is on by default");
  writeFileSync(config, text);
  const portFile = path.join(work, 'port');
  rmSync(portFile, { force: true });
  const ajard = start(ajardPath, ['--config', config, '--listen', '127.0.0.1:0', '--port-file', portFile,
    '--state-dir', path.join(work, 'state')]);
  ajard.port = await until('ajard port file', () => existsSync(portFile) && readFileSync(portFile, 'utf8').trim());
  ajard.config = config;
  return ajard;
}

const recordings = (work) => readdirSync(path.join(work, 'recordings'))
  .filter((n) => n.endsWith('.mcap')).sort().map((n) => path.join(work, 'recordings', n));

// Every record of `bytes` through @mcap/core's stream reader: [records, done (footer + magic)].
function streamRecords(bytes) {
  const reader = new McapStreamReader({ validateCrcs: true });
  reader.append(bytes);
  const records = [];
  for (let r; (r = reader.nextRecord()); ) records.push(r);
  return [records, reader.done()];
}

// The record framing by the specification alone (opcode u8, length u64, content): the offset where
// each whole record ends, and its opcode.
function framing(bytes) {
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const out = [];
  for (let at = 8; at + 9 <= bytes.length;) {
    const len = Number(view.getBigUint64(at + 1, true));
    if (at + 9 + len > bytes.length) break;
    out.push({ op: bytes[at], start: at, end: at + 9 + len });
    at += 9 + len;
  }
  return out;
}

const ajv = new Ajv2020({ strict: true, allErrors: true });
const decoder = new TextDecoder('utf-8', { fatal: true });

let work = null;
let fileBytes = null;

test('a recording of the whole procedure reads back with @mcap/core, valid and complete', { timeout: 180000 }, async () => {
  work = mkdtempSync(path.join(tmpdir(), 'ajar-blackbox-'));
  const ajard = await startAjard(work);
  const began = Date.now();
  const sim = start(ajarctlPath, ['--connect', `127.0.0.1:${ajard.port}`, 'simulate',
    path.join(root, 'config/scenarios/left-hinge-near.yaml'), '--config', ajard.config]);
  const { code } = await sim.exited;
  assert.equal(code, 0, `ajarctl simulate failed:\n${sim.output}\n--- ajard ---\n${ajard.output.slice(-3000)}`);
  const procedureMs = Date.now() - began;
  ajard.kill('SIGTERM');
  assert.equal((await ajard.exited).code, 0, ajard.output.slice(-3000));

  const files = recordings(work);
  assert.equal(files.length, 1, `one recording: ${files}`);
  const bytes = new Uint8Array(readFileSync(files[0]));
  fileBytes = bytes;
  console.log(`recording of the procedure: ${bytes.length} bytes in ${(procedureMs / 1000).toFixed(1)} s ` +
    `(${Math.round(bytes.length / (procedureMs / 60000))} bytes/min, start-up and shutdown included)`);

  // 1. @mcap/core, streaming: every record to the footer and the trailing magic, CRCs checked.
  const [records, done] = streamRecords(bytes);
  assert.ok(done, 'a cleanly stopped ajard leaves a complete file (footer, magic)');
  const schemas = new Map(), channels = new Map(), counts = new Map();
  let statistics = null, dataEnd = null;
  const messages = [];
  let inSummary = false;
  for (const r of records) {
    if (r.type === 'DataEnd') { dataEnd = r; inSummary = true; }
    if (r.type === 'Schema' && !inSummary) schemas.set(r.id, r);
    if (r.type === 'Channel' && !inSummary) channels.set(r.id, r);
    if (r.type === 'Statistics') statistics = r;
    if (r.type === 'Message') {
      assert.ok(!inSummary, 'no message after Data End');
      assert.ok(channels.has(r.channelId), 'a message after its channel');
      messages.push(r);
      counts.set(r.channelId, (counts.get(r.channelId) ?? 0) + 1);
    }
  }
  // 2. The CRCs as the specification defines them (computed here, not by the writer).
  const frames = framing(bytes);
  const dataEndRecord = frames.find((f) => f.op === 0x0f);
  assert.equal(dataEnd.dataSectionCrc, crc32(bytes.subarray(0, dataEndRecord.start)), 'Data End CRC');
  // 3. @mcap/core, indexed: footer, summary offsets, summary CRC, the summary's schemas and channels.
  const readable = { size: async () => BigInt(bytes.length), read: async (o, n) => bytes.subarray(Number(o), Number(o + n)) };
  const indexed = await McapIndexedReader.Initialize({ readable });
  assert.equal(indexed.channelsById.size, channels.size);
  assert.equal(indexed.schemasById.size, schemas.size);
  assert.ok(indexed.statistics, 'a Statistics record in the summary');
  // 4. What the daemon says it recorded: its Statistics, per channel, and its last counters.
  assert.equal(Number(statistics.messageCount), messages.length);
  for (const [id, n] of statistics.channelMessageCounts) assert.equal(counts.get(id) ?? 0, Number(n), `channel ${id}`);
  const topics = new Map([...channels.values()].map((c) => [c.topic, c]));
  for (const t of ['/ajar/wire', '/ajar/events', '/ajar/config', '/ajar/sessions', '/ajar/loop', '/ajar/recorder']) {
    assert.ok(counts.get(topics.get(t).id) > 0, `messages on ${t}`);
  }
  const recorderChannel = topics.get('/ajar/recorder').id;
  const last = JSON.parse(decoder.decode(messages.filter((m) => m.channelId === recorderChannel).at(-1).data));
  assert.equal(last.loop_samples - last.loop_dropped, counts.get(topics.get('/ajar/loop').id), 'loop samples recorded = taken - dropped');
  assert.equal(last.write_failures, 0);
  console.log(`drops: loop ${last.loop_dropped} of ${last.loop_samples}, io ${last.io_dropped} of ${last.io_records}; ` +
    `messages per topic: ${[...topics].map(([t, c]) => `${t} ${counts.get(c.id) ?? 0}`).join(', ')}`);

  // 5. Every schema a valid JSON Schema; every JSON message valid against its channel's schema.
  const validators = new Map();
  for (const c of channels.values()) {
    if (c.messageEncoding !== 'json') {
      assert.equal(c.topic, '/ajar/wire');
      assert.equal(c.schemaId, 0, 'the wire channel has no schema (its layout is in channels.hpp)');
      continue;
    }
    const s = schemas.get(c.schemaId);
    assert.equal(s.encoding, 'jsonschema');
    const schema = JSON.parse(decoder.decode(s.data));
    assert.equal(schema.title, s.name);
    validators.set(c.id, ajv.compile(schema));  // throws on an invalid schema
  }
  const wire = topics.get('/ajar/wire').id;
  const directions = [0, 0];
  for (const m of messages) {
    if (m.channelId === wire) {
      // u8 version, u8 direction, u64 session, u64 daemon time, then a whole frame: "AJAR", the
      // header's payload_length matching the bytes (docs/protocol.md).
      const v = new DataView(m.data.buffer, m.data.byteOffset, m.data.byteLength);
      assert.equal(m.data[0], 1);
      assert.ok(m.data[1] === 0 || m.data[1] === 1);
      directions[m.data[1]] += 1;
      assert.deepEqual([...m.data.subarray(18, 22)], [0x41, 0x4a, 0x41, 0x52], 'a frame starts with AJAR');
      assert.equal(v.getUint32(18 + 14, true), m.data.length - 18 - 22, 'payload_length');
      continue;
    }
    const validate = validators.get(m.channelId);
    const value = JSON.parse(decoder.decode(m.data));
    assert.ok(validate(value), `${channels.get(m.channelId).topic}: ${ajv.errorsText(validate.errors)}\n${decoder.decode(m.data)}`);
  }
  assert.ok(directions[0] > 0 && directions[1] > 0, 'frames in and out');
});

test('a copy cut at a random byte still yields every message before the cut', () => {
  assert.ok(fileBytes, 'the first test recorded a file');
  const seed = Number(process.env.AJAR_SEED ?? Math.floor(Math.random() * 2 ** 31));
  console.log(`cut campaign seed ${seed} (AJAR_SEED=${seed} replays it)`);
  let state = seed >>> 0;
  const next = () => { state = (Math.imul(state, 1664525) + 1013904223) >>> 0; return state; };
  const [all] = streamRecords(fileBytes);
  const allMessages = all.filter((r) => r.type === 'Message');
  const dataEnd = framing(fileBytes).find((f) => f.op === 0x0f).start;
  for (let i = 0; i < 20; ++i) {
    const cut = 8 + (next() % (dataEnd - 8));  // inside the data section: what a kill leaves
    const prefix = fileBytes.subarray(0, cut);
    const whole = framing(prefix).filter((f) => f.op === 0x05).length;  // messages wholly before
    const [records, done] = streamRecords(prefix);
    assert.equal(done, false);
    const got = records.filter((r) => r.type === 'Message');
    assert.equal(got.length, whole, `cut at ${cut} (seed ${seed}): every whole message read`);
    for (let k = 0; k < got.length; ++k) {
      assert.equal(got[k].sequence, allMessages[k].sequence);
      assert.equal(got[k].channelId, allMessages[k].channelId);
    }
  }
});

test('kill -9 of a recording ajard: the file reads to its last whole record; what was lost', { timeout: 60000 }, async () => {
  const w = mkdtempSync(path.join(tmpdir(), 'ajar-blackbox-kill-'));
  try {
    const ajard = await startAjard(w);
    // Idle recording for a while (the loop channel runs), then kill -9.
    await new Promise((r) => setTimeout(r, 3000));
    const killedAt = BigInt(Date.now()) * 1000000n;
    ajard.kill('SIGKILL');
    await ajard.exited;
    const files = recordings(w);
    assert.equal(files.length, 1);
    const bytes = new Uint8Array(readFileSync(files[0]));
    const [records, done] = streamRecords(bytes);
    assert.equal(done, false, 'no footer after kill -9');
    const messages = records.filter((r) => r.type === 'Message');
    assert.ok(messages.length > 0, 'the recording before the kill is readable');
    assert.equal(framing(bytes).at(-1).end, bytes.length, 'the file ends on a whole record');
    const lastLog = messages.reduce((m, r) => (r.logTime > m ? r.logTime : m), 0n);
    const firstLog = messages.reduce((m, r) => (r.logTime < m ? r.logTime : m), messages[0].logTime);
    const idleMs = Number(lastLog - firstLog) / 1e6;
    console.log(`kill -9: the last record on disk was logged ${Number(killedAt - lastLog) / 1e6} ms before the kill; ` +
      `idle recording: ${bytes.length} bytes over ${(idleMs / 1000).toFixed(1)} s ` +
      `(${Math.round(bytes.length / (idleMs / 60000))} bytes/min, start-up included)`);
  } finally {
    rmSync(w, { recursive: true, force: true });
  }
});

after(() => { if (work) rmSync(work, { recursive: true, force: true }); });

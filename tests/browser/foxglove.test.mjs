// Foxglove live (docs/console.md): ajar-console's Foxglove WebSocket port, held to the protocol by
// an independent client, @foxglove/ws-protocol's FoxgloveClient (npm, pinned in package-lock.json)
// over the `ws` package, against ajard on simulated hardware and the simulated camera.
//
// - serverInfo and advertise; every channel subscribed; telemetry, events, odometry as a
//   transform, the door scene and a camera image received, each message valid against the JSON
//   Schema its channel advertised (ajv) and, for foxglove.* schemas, against the official schema of
//   that name (@foxglove/schemas, npm); values against the scenario's truth (the measured width, the
//   handle, the plane's normal) and the daemon's telemetry (the transform), the image a PNG of the
//   camera's size;
// - refusals: no foxglove.websocket.v1 subprotocol, a foreign web page's Origin, a --foxglove
//   address off loopback (the console does not start);
// - a client that stops reading (its socket paused) while subscribed to the image: its queue drops
//   the oldest messages and it is disconnected (counted in /api/foxglove), while a second Foxglove
//   client and the console's own page keep receiving telemetry.
//
// Run: scripts/test (stage "browser"), or: node --test tests/browser/
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import path from 'node:path';
import { createRequire } from 'node:module';
import WebSocket from 'ws';
import wsProtocol from '@foxglove/ws-protocol';
import { withStack, until, build, scenarioPath, stopped } from './fixture.mjs';

const require = createRequire(import.meta.url);
const { FoxgloveClient } = wsProtocol;
const Ajv = require('ajv/dist/2020');  // the recorder's schemas are draft 2020-12
const official = require('@foxglove/schemas/jsonschema');

const foxgloveArgs = { consoleArgs: ['--observer', '--foxglove', '127.0.0.1:0'] };
const foxgloveUrl = (stack) => until('the Foxglove URL', () => (/Foxglove live at (ws:\/\/\S+)/.exec(stack.console.output) || [])[1]);

// A FoxgloveClient that keeps what it got: serverInfo, channels, statuses, messages by topic.
async function connect(url) {
  const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  const client = new FoxgloveClient({ ws });
  const got = { ws, client, serverInfo: null, channels: new Map(), statuses: [], byTopic: new Map(), totals: new Map(), subs: new Map(), unsubscribed: new Map(), closed: false };
  client.on('serverInfo', (i) => { got.serverInfo = i; });
  client.on('advertise', (channels) => { for (const c of channels) got.channels.set(c.id, c); });
  client.on('status', (s) => got.statuses.push(s));
  client.on('close', () => { got.closed = true; });
  client.on('message', ({ subscriptionId, timestamp, data }) => {
    const channel = got.subs.get(subscriptionId);
    if (!channel && got.unsubscribed.has(subscriptionId)) {  // in flight when we unsubscribed, or a leak
      got.unsubscribed.set(subscriptionId, got.unsubscribed.get(subscriptionId) + 1);
      return;
    }
    assert.ok(channel, `a message for subscription ${subscriptionId}, which this client never made`);
    const text = new TextDecoder().decode(new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
    const list = got.byTopic.get(channel.topic) || [];
    list.push({ timestamp, message: JSON.parse(text), bytes: data.byteLength });
    if (list.length > 50) list.shift();
    got.totals.set(channel.topic, (got.totals.get(channel.topic) || 0) + 1);
    got.byTopic.set(channel.topic, list);
  });
  got.subscribe = (topic) => {
    const channel = [...got.channels.values()].find((c) => c.topic === topic);
    assert.ok(channel, `channel ${topic} advertised`);
    got.subs.set(client.subscribe(channel.id), channel);
  };
  got.last = (topic) => { const l = got.byTopic.get(topic) || []; return l.length ? l[l.length - 1] : null; };
  got.count = (topic) => got.totals.get(topic) || 0;
  await until('serverInfo and advertise', () => got.serverInfo && got.channels.size > 0);
  return got;
}

const ajarctl = (stack, args) => new Promise((resolve) => {
  const c = spawn(path.join(build, 'client/ajarctl'), ['--connect', `127.0.0.1:${stack.daemonPort}`, ...args]);
  let out = '';
  c.stdout.on('data', (d) => { out += d; });
  c.stderr.on('data', (d) => { out += d; });
  c.on('exit', (code) => resolve({ code, out }));
});
const p3 = (v) => v.map((x) => x.toFixed(4));

test('Foxglove live: a @foxglove/ws-protocol client receives telemetry, the door scene and an image, each valid against its schema', { timeout: 90000 }, async () => {
  await withStack('foxglove', async (stack) => {
    const url = await foxgloveUrl(stack);
    const fox = await connect(url);
    assert.equal(fox.serverInfo.name, 'ajar-console');
    assert.deepEqual(fox.serverInfo.capabilities, [], 'read-only: no publishing, parameters or services');
    const topics = [...fox.channels.values()].map((c) => c.topic).sort();
    assert.deepEqual(topics, ['/ajar/camera/calibration', '/ajar/camera/image', '/ajar/door', '/ajar/events', '/ajar/telemetry', '/tf', '/tf_static']);

    // Every advertised schema compiles (strict JSON Schema), and foxglove.* names are the official ones.
    const ajv = new Ajv({ strict: true, allErrors: true });
    const officialAjv = new Ajv({ strict: false, allErrors: true });
    const validators = new Map();
    for (const c of fox.channels.values()) {
      assert.equal(c.encoding, 'json', c.topic);
      assert.equal(c.schemaEncoding, 'jsonschema', c.topic);
      const schema = JSON.parse(c.schema);
      assert.equal(schema.title, c.schemaName, `${c.topic}: the schema's title is its name`);
      const own = ajv.compile(schema);
      let theirs = null;
      if (c.schemaName.startsWith('foxglove.')) {
        const name = c.schemaName.slice('foxglove.'.length);
        assert.ok(official[name], `${c.schemaName} is a foxglove schema`);
        theirs = officialAjv.compile(official[name]);
      }
      validators.set(c.topic, { own, theirs });
    }
    for (const topic of topics) fox.subscribe(topic);

    // The door, measured in the base frame at the scenario's landmarks (ajarctl; the console observes).
    const L = await stack.landmarks();
    const P = L.points;
    for (const [what, pts] of [['width', [P.hinge_edge, P.moving_edge]], ['handle', [P.handle_axis, P.handle_free_end]],
      ['plane', [P.leaf_low_left, P.leaf_low_right, P.leaf_high_middle]]]) {
      const r = await ajarctl(stack, ['--frame', 'base', 'measure', what, ...pts.flatMap((p) => p3(p.base_m))]);
      assert.equal(r.code, 0, `measure ${what}: ${r.out}`);
    }

    const entities = () => { const d = fox.last('/ajar/door'); return d ? d.message.entities.map((e) => e.id).sort() : []; };
    await until('telemetry, events, odometry, camera mount, an image and the measured door', () =>
      fox.count('/ajar/telemetry') >= 5 && fox.count('/tf') >= 5 && fox.count('/tf_static') >= 1 &&
      fox.count('/ajar/camera/image') >= 2 && fox.count('/ajar/camera/calibration') >= 1 && fox.count('/ajar/events') >= 1 &&
      entities().join() === 'door_plane,door_width,handle', 30000);

    // Every message received is valid against its advertised schema and the official one.
    let checked = 0;
    for (const [topic, list] of fox.byTopic) {
      const { own, theirs } = validators.get(topic);
      for (const { message, timestamp } of list) {
        assert.ok(own(message), `${topic} against its advertised schema: ${JSON.stringify(own.errors)}`);
        if (theirs) assert.ok(theirs(message), `${topic} against the official schema: ${JSON.stringify(theirs.errors)}`);
        assert.ok(timestamp > 1_600_000_000_000_000_000n, `${topic}: log time in ns since the Unix epoch`);
        ++checked;
      }
    }
    assert.ok(checked >= 15);

    // Values: the transform is the telemetry's odometry; the scene is the scenario's door.
    const tf = fox.last('/tf').message;
    assert.equal(tf.parent_frame_id, 'odom');
    assert.equal(tf.child_frame_id, 'base_link');
    const tel = fox.last('/ajar/telemetry').message;
    assert.ok(Math.abs(tf.translation.x - tel.odometry_x_m) < 0.01 && Math.abs(tf.translation.y - tel.odometry_y_m) < 0.01);
    const yaw = 2 * Math.atan2(tf.rotation.z, tf.rotation.w);
    assert.ok(Math.abs(yaw - tel.base_yaw_odometry_rad) < 0.01, `yaw ${yaw} vs ${tel.base_yaw_odometry_rad}`);
    const mount = fox.last('/tf_static').message;
    assert.deepEqual([mount.parent_frame_id, mount.child_frame_id], ['base_link', 'camera']);

    const scene = fox.last('/ajar/door').message;
    const byId = Object.fromEntries(scene.entities.map((e) => [e.id, e]));
    for (const e of scene.entities) assert.equal(e.frame_id, 'base_link');
    const meta = (e, k) => Number(e.metadata.find((m) => m.key === k).value);
    const truthWidth = Math.hypot(...P.hinge_edge.base_m.map((x, i) => x - P.moving_edge.base_m[i]));
    assert.ok(Math.abs(meta(byId.door_width, 'width_m') - truthWidth) < 0.005, `width ${meta(byId.door_width, 'width_m')} vs ${truthWidth}`);
    const [h1, h2] = byId.door_width.spheres.map((s) => s.pose.position);
    assert.ok(Math.abs(h1.x - P.hinge_edge.base_m[0]) < 0.005 && Math.abs(h2.y - P.moving_edge.base_m[1]) < 0.005, 'hinge and moving edge where measured');
    assert.match(byId.door_width.texts[0].text, new RegExp(`opens ${L.truth.direction}`));
    const handleLength = Math.hypot(...P.handle_axis.base_m.map((x, i) => x - P.handle_free_end.base_m[i]));
    assert.ok(Math.abs(meta(byId.handle, 'length_m') - handleLength) < 0.005);
    // The plane's normal (toward the robot) against the yaw the scenario's door has.
    const [nx, ny] = byId.door_plane.metadata.find((m) => m.key === 'normal').value.split(' ').map(Number);
    assert.ok(nx < -0.9, `normal toward the robot (the door is ahead, +x): ${nx}`);
    const doorYaw = Math.atan2(-ny, -nx);
    assert.ok(Math.abs(doorYaw - L.truth.yaw_to_square_rad) < 0.02, `the plane's yaw ${doorYaw} vs the scenario's ${L.truth.yaw_to_square_rad}`);
    assert.equal(byId.door_plane.cubes.length, 1);

    const image = fox.last('/ajar/camera/image').message;
    assert.equal(image.format, 'png');
    assert.equal(image.frame_id, 'camera');
    const png = Buffer.from(image.data, 'base64');
    assert.equal(png.subarray(1, 4).toString(), 'PNG');
    assert.deepEqual([png.readUInt32BE(16), png.readUInt32BE(20)], [640, 480], 'the camera image, full size');
    // Its calibration (latched): the simulated camera's pinhole model.
    const cal = fox.last('/ajar/camera/calibration').message;
    assert.deepEqual([cal.frame_id, cal.width, cal.height], ['camera', 640, 480]);
    assert.deepEqual(cal.K, [570.3, 0, 319.5, 0, 570.3, 239.5, 0, 0, 1]);

    // An unknown channel and an unsupported op get a status message; nothing else changes.
    fox.ws.send(JSON.stringify({ op: 'subscribe', subscriptions: [{ id: 99, channelId: 4242 }] }));
    fox.ws.send(JSON.stringify({ op: 'getParameters', parameterNames: [] }));
    await until('two status messages', () => fox.statuses.length >= 2);
    assert.match(fox.statuses[0].message, /no channel 4242/);
    assert.match(fox.statuses[1].message, /getParameters.*not supported/);

    // Unsubscribed: no more telemetry on it. Messages the server sent before it read the unsubscribe
    // may still arrive (the protocol has no acknowledgement): they are counted for 300 ms; after
    // that none may come, while the other channels keep arriving.
    const telSub = [...fox.subs.entries()].find(([, c]) => c.topic === '/ajar/telemetry')[0];
    fox.client.unsubscribe(telSub);
    fox.subs.delete(telSub);
    fox.unsubscribed.set(telSub, 0);
    await new Promise((r) => setTimeout(r, 300));
    const inFlight = fox.unsubscribed.get(telSub);
    const tfBefore = fox.count('/tf');
    await new Promise((r) => setTimeout(r, 700));
    assert.equal(fox.unsubscribed.get(telSub), inFlight, 'telemetry after the unsubscribe had settled');
    assert.ok(fox.count('/tf') > tfBefore, 'the other subscriptions still deliver');
    fox.client.close();
  }, foxgloveArgs);
});

test('Foxglove live: refusals (no subprotocol, a foreign web page, an address off loopback)', { timeout: 60000 }, async () => {
  await withStack('foxglove-refusals', async (stack) => {
    const url = await foxgloveUrl(stack);
    const refused = (protocols, options) => new Promise((resolve) => {
      const ws = new WebSocket(url, protocols, options);
      ws.on('unexpected-response', (req, res) => { resolve(res.statusCode); ws.terminate(); });
      ws.on('open', () => { resolve('opened'); ws.close(); });
      ws.on('error', () => {});
    });
    assert.equal(await refused([]), 400, 'no foxglove.websocket.v1: refused');
    assert.equal(await refused(['foxglove.websocket.v1'], { origin: 'https://evil.example' }), 403);
    assert.equal(await refused(['foxglove.websocket.v1'], { origin: 'https://app.foxglove.dev' }), 'opened');
    const stats = await (await fetch(stack.url + 'api/foxglove')).json();
    assert.equal(stats.clients_refused, 2);
  }, foxgloveArgs);

  // Off loopback: the console refuses to start, naming the option.
  const c = spawn(path.join(build, 'console/ajar-console'), ['--listen', '127.0.0.1:0', '--scenario', scenarioPath,
    '--connect', '127.0.0.1:1', '--foxglove', '0.0.0.0:0']);
  let out = '';
  c.stderr.on('data', (d) => { out += d; });
  assert.ok(await stopped(c, 10000), 'the console exits');
  assert.equal(c.exitCode, 2);
  assert.match(out, /--foxglove 0\.0\.0\.0:0: not a loopback address/);
});

test('Foxglove live: a client that stops reading is dropped from, then disconnected; the page and other clients go on', { timeout: 90000 }, async () => {
  await withStack('foxglove-slow', async (stack) => {
    const url = await foxgloveUrl(stack);
    const slow = await connect(url);
    // Images fill the kernel's socket buffers; telemetry and odometry (40 messages/s) then overflow
    // its queue of 64 in the 5 s before a stalled client is disconnected, however slow the camera.
    for (const topic of ['/ajar/camera/image', '/ajar/telemetry', '/tf']) slow.subscribe(topic);
    await until('the slow client got an image', () => slow.count('/ajar/camera/image') >= 1);
    slow.ws._socket.pause();  // reads nothing more: the kernel's buffers fill, then the console's queue
    const good = await connect(url);
    good.subscribe('/ajar/telemetry');
    // The console's own page, as a WebSocket (its Origin is the console's).
    const page = new WebSocket(stack.url.replace('http', 'ws') + 'ws', { origin: stack.url.replace(/\/$/, '') });
    let pageTelemetry = 0;
    page.on('message', (data, binary) => { if (!binary && JSON.parse(data.toString()).type === 'telemetry') ++pageTelemetry; });
    const stats = async () => (await fetch(stack.url + 'api/foxglove')).json();
    let x = null;
    const s = await until('the slow client dropped from and disconnected', async () => {
      x = await stats();
      return x.messages_dropped > 0 && x.clients_disconnected_slow === 1 ? x : null;
    }, 60000).catch((e) => { throw new Error(`${e.message}: ${JSON.stringify(x)}, images the slow client got ${slow.count('/ajar/camera/image')}`); });
    assert.equal(s.clients, 1, 'the good client stays');
    const [tel0, page0] = [good.count('/ajar/telemetry'), pageTelemetry];
    await until('more telemetry for the good client and the page', () => good.count('/ajar/telemetry') >= tel0 + 10 && pageTelemetry >= page0 + 10, 15000);
    assert.equal(good.closed, false);
    page.close();
    good.client.close();
    slow.ws.terminate();
  }, foxgloveArgs);
});

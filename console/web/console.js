// Ajar operator console: the page. Plain JavaScript, no build step. It draws what ajar-console
// sends over the WebSocket (/ws) and sends the operator's clicks and commands back; every
// measurement and command goes to ajard through ajar-console (docs/console.md lists the messages).
//
// Never show the operator something that is no longer true (issue 23): a watchdog greys the image
// and says FROZEN when the frame or the daemon's telemetry is old; the EMERGENCY STOP says NO LINK
// when the page cannot reach ajard; markers follow the base (the console reprojects each pick for
// the frame it is drawn on); the role and the motion come from the daemon's events.
'use strict';

const $ = (id) => document.getElementById(id);
const STEPS = {
  width: { n: 2, colour: '#ffd34d', help: 'Click P1 on the HINGE side edge of the door, then P2 near the MOVING edge, at the same height. Then Send.' },
  handle: { n: 2, colour: '#5de0ff', help: 'Click the handle on its rotation AXIS, then its FREE END. Then Send.' },
  plane: { n: 16, colour: '#9dff6b', help: 'Click three (up to 16) well-spread points on the door leaf, or DRAG A RECTANGLE on the door to pick 16 spread points. Then Send.' },
  contact: { n: 1, colour: '#ff8cf0', help: 'After aligning, click the contact point on the handle. Then Send, then Engage.' },
};
const LINK_TIMEOUT_MS = 1000;   // no word from the console for this long: the link is down

let ws = null;
let state = null;           // the latest "state" snapshot
let colour = null;          // ImageBitmap of the latest colour frame
let depth = null;           // ImageBitmap of the latest depth overlay
let frameSeq = 0;
let frameMeta = null;       // {seq, age_ms, pose, markers} of the frame drawn
let frameAt = 0;            // page time the drawn frame arrived
const metas = new Map();    // seq -> frame meta, the last few
let imgW = 640, imgH = 480;
let zoom = 1, viewX = 0, viewY = 0;  // the source rectangle's top-left (image pixels)
let drag = null;            // {x0, y0, x1, y1} canvas CSS pixels while the mouse is down
let pendingHover = null;
let badPick = null;         // {step, index} named by the daemon's refusal
let lastMessageAt = 0;      // page time the link was last known up (open, or any message)
let lastWordAt = 0;         // page time of the console's last message
let lastTick = null;        // the console's last tick
let telemetryAt = 0;        // page time of the last telemetry sample
let lastTelemetry = null;
let standoffEdited = false; // the operator typed a standoff: the default no longer overwrites it
let live = { link: false, daemon: false, frozen: true, why: 'connecting' };
const samples = [];         // telemetry for the plots
const canvas = $('image');
const ctx = canvas.getContext('2d');

function linkUp() { return !!ws && ws.readyState === WebSocket.OPEN && performance.now() - lastMessageAt < LINK_TIMEOUT_MS; }
function send(obj) {
  if (ws && ws.readyState === WebSocket.OPEN) { ws.send(JSON.stringify(obj)); return true; }
  return false;
}
function imageMessage(text) { $('image-msg').textContent = text || ''; $('image-msg').dataset.from = ''; }

// ---- WebSocket -------------------------------------------------------------------------------

function connect() {
  ws = new WebSocket(`ws://${location.host}/ws`);
  ws.binaryType = 'arraybuffer';
  ws.onopen = () => { lastMessageAt = performance.now(); send({ op: 'alive' }); watchdog(); };
  ws.onclose = () => { watchdog(); setTimeout(connect, 1000); };  // keeps retrying
  ws.onerror = () => {};
  ws.onmessage = (ev) => {
    lastMessageAt = lastWordAt = performance.now();
    if (typeof ev.data !== 'string') return onFrame(ev.data);
    const m = JSON.parse(ev.data);
    if (m.type === 'state') { state = m; updateState(); }
    else if (m.type === 'frame') { m.arrived = performance.now(); metas.set(m.seq, m); if (metas.size > 12) metas.delete(metas.keys().next().value); }
    else if (m.type === 'tick') lastTick = m;
    else if (m.type === 'telemetry') onTelemetry(m);
    else if (m.type === 'log') m.entries.forEach(addLog);
    else if (m.type === 'hover') onHover(m);
    else if (m.type === 'pick_refused') {
      showResult($('result'), { ok: false, code: 'PICK', field: m.field, message: m.message });
      imageMessage('pick refused: ' + m.message);
    } else if (m.type === 'notice') { addLog('notice: ' + m.text); imageMessage(m.text); }
  };
}
// The console feeds the robot's deadman only while this page says it is alive.
setInterval(() => send({ op: 'alive' }), 250);

async function onFrame(buffer) {
  const view = new DataView(buffer);
  const kind = view.getUint8(0);
  const seq = view.getUint32(1);
  const bitmap = await createImageBitmap(new Blob([buffer.slice(5)], { type: 'image/png' }));
  if (kind === 1) {
    if (colour) colour.close();
    colour = bitmap; frameSeq = seq;
    const meta = metas.get(seq);
    frameMeta = meta || null;
    frameAt = meta ? meta.arrived : performance.now();
    if (imgW !== bitmap.width || imgH !== bitmap.height) {
      imgW = bitmap.width; imgH = bitmap.height;
      document.documentElement.style.setProperty('--aspect', String(imgW / imgH));
    }
    $('frame-info').textContent = `frame ${seq} · ${imgW}×${imgH}`;
  } else {
    if (depth) depth.close();
    depth = bitmap;
  }
  render();
}

// ---- Watchdog: the age of the image and of the daemon's telemetry; the link -----------------------

function frameAgeMs() { return frameMeta ? frameMeta.age_ms + (performance.now() - frameAt) : (colour ? performance.now() - frameAt : Infinity); }
function telemetryAgeMs() { return telemetryAt ? performance.now() - telemetryAt : Infinity; }
const secs = (ms) => (ms >= 1000 ? (ms / 1000).toFixed(1) + ' s' : Math.round(ms) + ' ms');

function watchdog() {
  const limit = (state && state.frozen_after_ms) || 600;
  const link = linkUp();
  const daemon = link && !!state && state.connection.connected && !(lastTick && lastTick.daemon === false);
  const fAge = frameAgeMs(), tAge = telemetryAgeMs();
  let why = '', age = 0;
  if (!link) { why = ws && ws.readyState === WebSocket.OPEN ? 'console not answering' : 'no link to the console'; age = lastWordAt ? performance.now() - lastWordAt : Infinity; }
  else if (!daemon) { why = 'no link to ajard'; age = tAge; }
  else if (fAge > limit) { why = 'camera'; age = fAge; }
  else if (tAge > limit) { why = 'no telemetry from ajard'; age = tAge; }
  // ajard answers: connected and its telemetry is fresh. Otherwise nothing it said is current.
  const answering = daemon && tAge <= limit;
  live = { link, daemon, answering, frozen: !!why, why, frameAge: fAge, telemetryAge: tAge };
  const badge = $('live-badge');
  badge.className = why ? 'frozen' : '';
  badge.textContent = why ? `FROZEN ${isFinite(age) ? secs(age) : ''} — ${why}` : `LIVE ${secs(fAge)}`;
  badge.dataset.state = why ? 'frozen' : 'live';
  canvas.classList.toggle('frozen', !!why);
  $('frozen-cover').hidden = !why;
  // The EMERGENCY STOP never silently does nothing: without a link to ajard it says so.
  const es = $('estop');
  const ok = link && daemon && tAge <= limit;
  es.classList.toggle('nolink', !ok);
  $('estop-text').textContent = ok ? 'EMERGENCY STOP' : 'NO LINK — use the robot\u2019s hardware e-stop';
  $('estop-key').textContent = ok ? 'Esc' : '';
  es.dataset.link = ok ? 'up' : 'down';
  // A jog held while ajard stops answering ends here (zero sent): its buttons are disabled below and
  // a disabled button may never see its release.
  if (!answering && jogHeld) jogStop();
  updateConn();
  updateHeader();
  updateHud();
}
setInterval(watchdog, 100);

// ---- Image region ------------------------------------------------------------------------------

function clampView() {
  const sw = imgW / zoom, sh = imgH / zoom;
  viewX = Math.min(Math.max(0, viewX), imgW - sw);
  viewY = Math.min(Math.max(0, viewY), imgH - sh);
}
// Canvas CSS pixel -> image pixel, pixel centres at integers.
function toImage(x, y) {
  return { u: viewX + x * (imgW / zoom) / canvas.clientWidth - 0.5,
           v: viewY + y * (imgH / zoom) / canvas.clientHeight - 0.5 };
}
// Image pixel -> canvas backing-store pixel.
function toCanvas(u, v) {
  return { x: (u + 0.5 - viewX) * zoom * canvas.width / imgW, y: (v + 0.5 - viewY) * zoom * canvas.height / imgH };
}
function setZoom(z, u, v) {
  const old = zoom;
  zoom = Math.min(8, Math.max(1, z));
  if (u !== undefined) {  // keep the image point under the cursor still
    viewX = u + 0.5 - (u + 0.5 - viewX) * old / zoom;
    viewY = v + 0.5 - (v + 0.5 - viewY) * old / zoom;
  }
  clampView();
  $('zoom-label').textContent = zoom + '×';
  render();
}
// The canvas's backing store follows its size on screen (the image scales with the window).
function fitCanvas() {
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(1, Math.round(canvas.clientWidth * dpr)), h = Math.max(1, Math.round(canvas.clientHeight * dpr));
  if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; render(); }
}
new ResizeObserver(fitCanvas).observe(canvas);

// Where each pick's marker is on the drawn frame: the console reprojected it for that frame's pose.
function markersFor(name) {
  if (frameMeta && frameMeta.markers && frameMeta.markers[name] && state && frameMeta.markers[name].length === (state.picks[name] || []).length) return frameMeta.markers[name];
  return ((state && state.picks[name]) || []).map((p) => ({ u: p.u, v: p.v, place: p.place || 'here' }));
}

function render() {
  const scale = canvas.width / Math.max(1, canvas.clientWidth);
  ctx.imageSmoothingEnabled = zoom < 2;
  ctx.fillStyle = '#000';
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  const sw = imgW / zoom, sh = imgH / zoom;
  if (colour) ctx.drawImage(colour, viewX, viewY, sw, sh, 0, 0, canvas.width, canvas.height);
  if (depth && $('overlay').getAttribute('aria-pressed') === 'true') {
    ctx.globalAlpha = 0.5;
    ctx.drawImage(depth, viewX, viewY, sw, sh, 0, 0, canvas.width, canvas.height);
    ctx.globalAlpha = 1;
  }
  if (!colour) {
    ctx.fillStyle = '#a3acb8'; ctx.font = `${16 * scale}px sans-serif`;
    ctx.fillText('waiting for the camera…', canvas.width * 0.35, canvas.height / 2);
  }
  if (state) {
    for (const [name, step] of Object.entries(STEPS)) {
      const active = state.active_step === name;
      markersFor(name).forEach((p, i) => {
        if (p.place === 'out' || p.u === undefined) return;
        const c = toCanvas(p.u, p.v);
        const bad = badPick && badPick.step === name && badPick.index === i;
        const stale = p.place === 'stale';
        const col = bad ? '#ff3b3b' : stale ? '#9a9a9a' : step.colour;
        ctx.lineWidth = (active ? 2.5 : 1.5) * scale;
        ctx.strokeStyle = col;
        ctx.globalAlpha = active ? 1 : 0.6;
        ctx.setLineDash(stale || p.place === 'moved' ? [4 * scale, 3 * scale] : []);
        const r = (bad ? 11 : 8) * scale;
        ctx.beginPath(); ctx.arc(c.x, c.y, r, 0, 2 * Math.PI); ctx.stroke();
        ctx.setLineDash([]);
        ctx.beginPath(); ctx.moveTo(c.x - 3 * scale, c.y); ctx.lineTo(c.x + 3 * scale, c.y); ctx.moveTo(c.x, c.y - 3 * scale); ctx.lineTo(c.x, c.y + 3 * scale); ctx.stroke();
        ctx.font = `bold ${13 * scale}px sans-serif`; ctx.fillStyle = col;
        ctx.fillText(String(i + 1), c.x + 10 * scale, c.y - 9 * scale);
        ctx.globalAlpha = 1;
      });
    }
  }
  if (drag) {
    ctx.strokeStyle = '#9dff6b'; ctx.setLineDash([6, 4]); ctx.lineWidth = 1.5 * scale;
    ctx.strokeRect(drag.x0 * scale, drag.y0 * scale, (drag.x1 - drag.x0) * scale, (drag.y1 - drag.y0) * scale);
    ctx.setLineDash([]);
  }
}

function canvasPoint(ev) {
  const r = canvas.getBoundingClientRect();
  return { x: ev.clientX - r.left, y: ev.clientY - r.top };
}
canvas.addEventListener('mousemove', (ev) => {
  const p = canvasPoint(ev);
  if (drag) { drag.x1 = p.x; drag.y1 = p.y; render(); }
  const { u, v } = toImage(p.x, p.y);
  pendingHover = { op: 'hover', u, v, seq: frameSeq };
  $('live-where').textContent = '(under the cursor)';
  $('live-pixel').textContent = `u ${u.toFixed(1)}  v ${v.toFixed(1)}`;
});
// Live data shows nothing once the cursor has left the image (never the last values).
canvas.addEventListener('mouseleave', () => {
  pendingHover = null;
  $('live-where').textContent = '(cursor not on the image)';
  ['pixel', 'cx', 'cy', 'cz', 'bx', 'by', 'bz', 'depth'].forEach((k) => { $('live-' + k).textContent = '—'; });
});
setInterval(() => { if (pendingHover) { send(pendingHover); pendingHover = null; } }, 50);
canvas.addEventListener('mousedown', (ev) => {
  if (ev.button !== 0) return;
  const p = canvasPoint(ev);
  drag = { x0: p.x, y0: p.y, x1: p.x, y1: p.y };
});
window.addEventListener('mouseup', (ev) => {
  if (!drag) return;
  const d = drag; drag = null;
  render();
  const moved = Math.hypot(d.x1 - d.x0, d.y1 - d.y0);
  if (moved < 6 && ev.target !== canvas) return;
  // Picks on a frozen image are refused: what it shows may no longer be there.
  if (live.frozen) {
    const text = `the image is FROZEN (${live.why}): nothing picked`;
    imageMessage(text);
    showResult($('result'), { ok: false, code: 'FROZEN', field: 'frame', message: text });
    return;
  }
  imageMessage('');
  const a = toImage(d.x0, d.y0);
  if (moved < 6) send({ op: 'pick', u: a.u, v: a.v, seq: frameSeq });
  else {
    const b = toImage(d.x1, d.y1);
    send({ op: 'rect', u0: a.u, v0: a.v, u1: b.u, v1: b.v, seq: frameSeq });
  }
});
canvas.addEventListener('wheel', (ev) => {
  ev.preventDefault();
  const p = canvasPoint(ev);
  const { u, v } = toImage(p.x, p.y);
  setZoom(ev.deltaY < 0 ? zoom * 2 : zoom / 2, u, v);
}, { passive: false });
$('zoom-in').onclick = () => setZoom(zoom * 2, viewX + imgW / zoom / 2 - 0.5, viewY + imgH / zoom / 2 - 0.5);
$('zoom-out').onclick = () => setZoom(zoom / 2, viewX + imgW / zoom / 2 - 0.5, viewY + imgH / zoom / 2 - 0.5);
$('overlay').onclick = () => {
  const on = $('overlay').getAttribute('aria-pressed') !== 'true';
  $('overlay').setAttribute('aria-pressed', String(on));
  send({ op: 'overlay', on });
  render();
};

// ---- Live data -----------------------------------------------------------------------------------

const fmt = (x, d = 3) => (x === undefined || x === null ? '—' : (x >= 0 ? '+' : '') + x.toFixed(d));
function onHover(m) {
  if ($('live-where').textContent !== '(under the cursor)') return;  // the cursor left meanwhile
  if (!m.ok) {
    ['cx', 'cy', 'cz', 'bx', 'by', 'bz'].forEach((k) => { $('live-' + k).textContent = '—'; });
    $('live-depth').innerHTML = `<span class="error">${escapeHtml(m.message || '')}</span>`;
    return;
  }
  $('live-cx').textContent = fmt(m.camera_m[0]);
  $('live-cy').textContent = fmt(m.camera_m[1]);
  $('live-cz').textContent = fmt(m.camera_m[2]);
  if (m.base_m) {
    $('live-bx').textContent = fmt(m.base_m[0]);
    $('live-by').textContent = fmt(m.base_m[1]);
    $('live-bz').textContent = fmt(m.base_m[2]);
  } else {
    $('live-bx').textContent = 'needs the daemon\u2019s calibration';
    $('live-by').textContent = $('live-bz').textContent = '';
  }
  $('live-depth').textContent = `${m.depth_m.toFixed(3)} m` + (m.from_window ? '  (hole: median of the neighbours)' : '');
}

// ---- Parameter region ----------------------------------------------------------------------------

function escapeHtml(s) {
  return String(s).replace(/[&<>"]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;' }[c]));
}
const deg = (rad) => (rad * 180 / Math.PI).toFixed(2) + '°';
// A wire Vec3 is {x, y, z} (ajard's messages, docs/protocol.md section 8); the page's own points are [x, y, z].
const vec = (v) => '(' + (Array.isArray(v) ? v : [v.x, v.y, v.z]).map((x) => x.toFixed(3)).join(', ') + ')';

// An Ack's fields (wire names: the reply is {ok, acknowledged, state, then the body's fields}).
function describeValues(step, v) {
  if (!v) return '';
  if (step === 'width') return `width ${v.length_m.toFixed(3)} m, door opens ${v.direction}\nP1 base ${vec(v.p1_base_m)}\nP2 base ${vec(v.p2_base_m)}`;
  if (step === 'handle') return `handle length ${v.length_m.toFixed(3)} m, turns ${v.direction}\naxis base ${vec(v.p1_base_m)}\nend base ${vec(v.p2_base_m)}`;
  if (step === 'plane') return `normal ${vec(v.normal)}\nyaw to square up ${v.yaw_deviation_rad >= 0 ? '+' : ''}${v.yaw_deviation_rad.toFixed(4)} rad (${deg(v.yaw_deviation_rad)})\n` +
    `wheels L ${v.left_wheel_rad.toFixed(3)} rad / R ${v.right_wheel_rad.toFixed(3)} rad = ${v.left_counts} / ${v.right_counts} counts\n` +
    `rms residual ${(v.rms_residual_m * 1000).toFixed(1)} mm, ${v.point_count} points`;
  if (step === 'contact') return `contact base ${vec(v.contact_base_m)}\nreach margin ${v.reach_margin_m.toFixed(3)} m`;
  return '';
}

// The refusal's field -> which pick it names (p1/p2/points[i]/contact), else the field itself.
function pickOfField(step, field) {
  if (!field) return null;
  let m = /^p([12])/.exec(field);
  if (m) return Number(m[1]) - 1;
  m = /^points\[(\d+)\]/.exec(field);
  if (m) return Number(m[1]);
  if (/^contact/.test(field)) return 0;
  return null;
}

function showResult(el, r, step) {
  el.className = el.className.replace(/\b(ok|refused)\b/g, '').trim() + ' ' + (r.ok ? 'ok' : 'refused');
  if (r.ok) {
    el.textContent = (describeValues(step, r.acknowledged ? r : null) || 'accepted') + (r.note ? '\n' + r.note : '');
    el.dataset.ok = 'true';
    el.dataset.note = r.note || '';
    return;
  }
  el.dataset.ok = 'false';
  el.dataset.code = r.code;
  el.dataset.field = r.field || '';
  const field = r.field ? ` <span class="field bad" data-field="${escapeHtml(r.field)}">${escapeHtml(r.field)}</span>` : '';
  el.innerHTML = `${r.sent === false ? 'NOT SENT' : 'REFUSED'} <b>${escapeHtml(r.code)}</b>${field}\n${escapeHtml(r.message)}`;
}

function stepStale(name) {
  const t = lastTelemetry;
  if (!t) return false;
  return !!t.staleness && ((name === 'plane' && t.staleness.plane) || (name === 'contact' && t.staleness.contact));
}

function updateSteps() {
  const st = state.status || {};
  document.querySelectorAll('#steps button').forEach((b) => {
    const name = b.dataset.step;
    // Status has every block; has_width, has_handle, has_plane, has_contact say which are stored.
    const stored = !!st['has_' + name];
    const stale = stored && stepStale(name);
    b.classList.toggle('active', name === state.active_step);
    b.classList.toggle('stored', stored && !stale);
    b.classList.toggle('stale', stale);
    b.setAttribute('aria-pressed', String(name === state.active_step));
    b.querySelector('.mark').textContent = stale ? ' STALE' : stored ? ' ✓' : '';
  });
  const step = state.active_step;
  $('step-help').textContent = STEPS[step].help;
  const result = state.results[step];
  badPick = null;
  if (result && !result.ok) {
    const i = pickOfField(step, result.field);
    if (i !== null) badPick = { step, index: i };
  }
  const flags = ((state.guidance && state.guidance.flags) || []).filter((f) => f.step === step);
  const markers = markersFor(step);
  const list = $('pick-list');
  list.innerHTML = '';
  (state.picks[step] || []).forEach((p, i) => {
    const li = document.createElement('li');
    const place = p.place || 'here';
    const shown = markers[i] && markers[i].place === 'out' ? '  [not in this image]' : '';
    const moved = place === 'moved' ? `  [moved: ${p.moved}: sent transformed]` : place === 'stale' ? `  [STALE: ${p.moved}: pick again]` : '';
    li.textContent = `u ${p.u.toFixed(0)} v ${p.v.toFixed(0)}  cam ${vec(p.camera_m)}` + (p.from_window ? '  (hole: median)' : '') + moved + shown;
    li.dataset.place = place;
    li.className = place === 'stale' ? 'stale' : shown ? 'out' : '';
    flags.filter((f) => f.index === i).forEach((f) => {
      const span = document.createElement('span');
      span.className = 'flag'; span.textContent = '  ⚠ ' + f.text;
      li.appendChild(span);
    });
    if (badPick && badPick.index === i) li.className = 'bad';
    list.appendChild(li);
  });
  const el = $('result');
  if (result) showResult(el, result, step);
  else if (st[step]) {
    const stale = stepStale(step);
    el.className = 'result ' + (stale ? 'refused' : 'ok'); el.dataset.ok = 'stored';
    el.textContent = (stale ? `STALE in the daemon: the base moved since it was measured: measure the ${step} again\n` : 'stored in the daemon:\n') + describeValues(step, st[step]);
  } else { el.className = 'result'; el.dataset.ok = ''; el.textContent = ''; }
  if (step === 'width' || step === 'handle') {
    const hp = state.guidance && state.guidance.hinge_problem;
    if (hp && !(result && !result.ok)) { el.className = 'result refused'; el.dataset.warning = 'hinge'; el.textContent = 'WARNING: ' + hp + '\n' + el.textContent; }
    else delete el.dataset.warning;
  }
}
document.querySelectorAll('#steps button').forEach((b) => { b.onclick = () => send({ op: 'step', step: b.dataset.step }); });
$('btn-send').onclick = () => send({ op: 'send' });
$('btn-undo').onclick = () => send({ op: 'undo' });
$('btn-clear').onclick = () => send({ op: 'clear' });

// ---- Motion and commands -----------------------------------------------------------------------------

// Stop and EmergencyStop: never a button that silently does nothing.
function stopAll(kind) {
  jogStop();
  const name = kind === 'estop' ? 'EMERGENCY STOP' : 'STOP';
  const sent = linkUp() && send({ op: kind });
  if (!sent) imageMessage(`${name}: NO LINK to the console (not sent): use the robot\u2019s hardware e-stop`);
  else if ($('estop').dataset.link === 'down') imageMessage(`${name} sent to the console, but ajard is not answering (NO LINK): use the robot\u2019s hardware e-stop`);
  else imageMessage(`${name} sent`);
}

// Jog: while a jog button or an arrow key is held the page sends a Drive request every 100 ms (the
// daemon stops the base when they stop coming: the drive command timeout); release, leaving the
// button, a cancelled pointer, losing focus or a hidden page send zero at once.
const JOG = { fwd: [1, 0], back: [-1, 0], left: [0, 1], right: [0, -1] };
const KEY_JOG = { ArrowUp: 'fwd', ArrowDown: 'back', ArrowLeft: 'left', ArrowRight: 'right' };
let jogHeld = null;
function jogStart(dir) {
  if (!state || !state.features.drive || jogHeld === dir) return;
  if (!linkUp() || !live.daemon) { imageMessage('jog: NO LINK to ajard: nothing sent'); return; }
  if (!live.answering) { imageMessage('jog: ajard is not answering: nothing sent'); return; }
  jogHeld = dir;
  document.querySelectorAll('[data-jog]').forEach((b) => b.classList.toggle('held', b.dataset.jog === dir));
  jogSend();
  updateHeader();
}
function jogSend() {
  if (!jogHeld) return;
  const m = state.model || {};
  const [l, a] = JOG[jogHeld];
  send({ op: 'drive', linear: l * 0.5 * (m.max_linear_speed_m_s || 0), angular: a * 0.5 * (m.max_angular_speed_rad_s || 0) });
}
function jogStop() {
  if (!jogHeld) return;
  jogHeld = null;
  document.querySelectorAll('[data-jog]').forEach((b) => b.classList.remove('held'));
  send({ op: 'drive', linear: 0, angular: 0 });
  updateHeader();
}
setInterval(jogSend, 100);
document.querySelectorAll('[data-jog]').forEach((b) => {
  b.addEventListener('pointerdown', (ev) => {
    if (ev.pointerType === 'mouse' && ev.button !== 0) return;
    ev.preventDefault();
    jogStart(b.dataset.jog);
  });
  for (const e of ['pointerup', 'pointercancel', 'pointerleave', 'pointerout', 'lostpointercapture']) b.addEventListener(e, jogStop);
  b.addEventListener('contextmenu', (ev) => ev.preventDefault());  // a long touch is a jog, not a menu
});
window.addEventListener('blur', jogStop);
document.addEventListener('visibilitychange', () => { if (document.hidden) jogStop(); });
$('jog-pad').addEventListener('focusout', jogStop);
canvas.addEventListener('blur', jogStop);

$('standoff').addEventListener('input', () => { standoffEdited = true; });
$('btn-approach').onclick = () => {
  const v = Number($('standoff').value.replace(',', '.'));
  if (!isFinite(v) || v <= 0) { $('command-result').className = 'result one refused'; $('command-result').textContent = 'standoff: a distance in metres, e.g. 0.85'; return; }
  send({ op: 'approach', standoff_m: v });
};
$('btn-align').onclick = () => send({ op: 'align' });
$('btn-engage').onclick = () => send({ op: 'engage' });
$('btn-stop').onclick = () => stopAll('stop');
$('btn-stop-top').onclick = () => stopAll('stop');
$('estop').onclick = () => stopAll('estop');
$('btn-reset').onclick = () => send({ op: 'reset', clear: false });
$('btn-reset-clear').onclick = () => $('confirm-clear').showModal();
$('confirm-cancel').onclick = () => $('confirm-clear').close();
$('confirm-ok').onclick = () => { $('confirm-clear').close(); send({ op: 'reset', clear: true }); };
$('btn-take-over').onclick = () => send({ op: 'take_over' });

// Keys, whatever has focus (text fields included): Space = Stop, Escape = EmergencyStop. Arrow keys
// jog only while the image or the jog pad has focus, and never change a field.
const isField = (el) => el && (el.tagName === 'INPUT' || el.tagName === 'TEXTAREA' || el.tagName === 'SELECT' || el.isContentEditable);
const jogFocus = () => document.activeElement === canvas || (document.activeElement && $('jog-pad').contains(document.activeElement));
window.addEventListener('keydown', (ev) => {
  if (ev.key === 'Escape') { ev.preventDefault(); ev.stopPropagation(); stopAll('estop'); return; }
  if (ev.key === ' ' || ev.code === 'Space') { ev.preventDefault(); ev.stopPropagation(); if (!ev.repeat) stopAll('stop'); return; }
  if (KEY_JOG[ev.key]) {
    if (jogFocus()) { ev.preventDefault(); jogStart(KEY_JOG[ev.key]); }
    else if (isField(ev.target)) ev.preventDefault();
  }
}, true);
window.addEventListener('keyup', (ev) => {
  // a focused button would click on Space's keyup: Space is Stop, nothing else
  if (ev.key === ' ' || ev.code === 'Space') { ev.preventDefault(); ev.stopPropagation(); }
  if (KEY_JOG[ev.key]) jogStop();
}, true);
window.addEventListener('keypress', (ev) => { if (ev.key === ' ') { ev.preventDefault(); ev.stopPropagation(); } }, true);

// ---- Header: connection, role, state and motion, fault, deadman ----------------------------------

function updateConn() {
  const el = $('conn');
  const page = live.link;
  const daemon = live.daemon;
  el.className = 'pill ' + (live.answering ? 'ok' : page ? 'partial' : '');
  $('conn-text').textContent = !page ? (ws && ws.readyState === WebSocket.OPEN ? 'console not answering' : 'console unreachable')
    : !daemon ? `ajard: ${state ? state.connection.message : '…'}`
      : !live.answering ? 'ajard not answering'
        : 'ajard' + (state.welcome && state.welcome.driver_kind ? ` (${state.welcome.driver_kind})` : '');
  el.title = page && state ? `page ↔ console ↔ ajard ${state.connection.daemon}` : 'page ↔ console ↔ ajard';
}

function updateHeader() {
  const role = state && live.link ? state.role : '';
  const observer = role === 'observer';
  // Like the state and the fault: what ajard last said is not shown as current while it is silent.
  $('role').textContent = !live.answering ? 'unknown' : role || '—';
  $('role-box').classList.toggle('observer', observer && live.answering);
  $('role-box').title = !live.answering && role ? `last known: ${role}` : state && state.controller ? state.controller : '';
  $('btn-take-over').hidden = !(live.link && live.daemon && observer);
  $('deadman').hidden = !$('btn-take-over').hidden;  // an observer feeds no deadman: Take over there
  const fed = live.link && live.answering && role === 'controller' && state.connection.heartbeat;
  $('deadman-text').textContent = !live.link ? 'NOT fed (no link)' : !live.answering ? 'unknown' : observer ? 'not ours (observer)' : fed ? 'fed by this page' : 'NOT fed';
  $('deadman').classList.toggle('unfed', !fed);
  const fault = state && state.status ? state.status.latched_fault : 'OK';
  $('fault').textContent = !live.answering ? 'unknown' : fault === 'OK' ? 'none' : fault;
  $('fault-box').classList.toggle('latched', fault !== 'OK');
  const st = lastTelemetry ? lastTelemetry.state : state && state.status ? state.status.state : null;
  $('state').textContent = !live.answering ? 'unknown' : st || '—';
  // What moves now: the page's own jog, the daemon's motion events, or telemetry's "moving".
  let motion = '';
  // The daemon's motion events name the motion; telemetry (20 Hz) says whether anything still moves.
  const t = lastTelemetry;
  const busy = t && (t.moving || t.state === 'aligning' || t.state === 'engaging');
  if (jogHeld) motion = 'jogging';
  else if (state && state.motion && busy) motion = state.motion;
  else if (busy) motion = t.state === 'engaging' ? 'engaging' : 'moving';
  if (!live.answering && !jogHeld) motion = '';
  $('motion').textContent = motion ? '· ' + motion.toUpperCase() : '';
  $('state-box').dataset.motion = motion;
  $('state-box').title = $('state').textContent + ' ' + $('motion').textContent;
  $('hud-motion').textContent = motion ? motion.toUpperCase() : '';
  // Commands need an ajard that answers (a click would act later on a state nobody sees) and, for an
  // observer, a request the message table lets observers send (state.controller_only, the table's
  // sender column): else their buttons are disabled. STOP and EMERGENCY STOP never are.
  const off = (op) => !live.answering || (observer && !!(state && state.controller_only && state.controller_only[op]));
  document.querySelectorAll('[data-op]').forEach((b) => { b.disabled = off(b.dataset.op); });
  $('btn-approach').disabled = off('approach') || !(state && state.features.drive);
  document.querySelectorAll('[data-jog]').forEach((b) => { b.disabled = off('drive') || !(state && state.features.drive); });
  $('drive-box').classList.toggle('off', !(state && state.features.drive));
}

function updateGuidance() {
  const g = (state && state.guidance) || {};
  const lines = [];
  if (g.default_standoff_m !== undefined && !standoffEdited && document.activeElement !== $('standoff')) $('standoff').value = g.default_standoff_m.toFixed(2);
  const s = Number($('standoff').value.replace(',', '.'));
  if (g.default_standoff_m !== undefined) lines.push(`${g.default_standoff_m.toFixed(2)} m keeps the measured door in view`);
  for (const v of g.view || []) {
    if (v.min_standoff_m === null) lines.push(`${v.name}: not in view now (${v.why.replace('leaves the image at', 'off')})`);
    else if (isFinite(s) && s < v.min_standoff_m - 1e-6) lines.push(`at ${s.toFixed(2)} m the ${v.name} ${v.why} (keep ≥ ${v.min_standoff_m.toFixed(2)} m)`);
  }
  $('guidance').textContent = lines.join('\n');
  $('guidance').dataset.warnings = String(lines.filter((l) => /^at |not in view/.test(l)).length);
}
$('standoff').addEventListener('input', updateGuidance);

// A refusal is shown on the image too (above the fold on any screen) until the next answer.
let lastAnswers = {};
function showRefusalsOnImage() {
  const answers = { step: state.results[state.active_step] || null, command: state.last_command ? state.last_command.reply : null };
  for (const [k, r] of Object.entries(answers)) {
    // Before any command last_command is null: its key is the empty answer's.
    const key = JSON.stringify(r) + (k === 'command' ? (state.last_command ? state.last_command.at : '') : state.active_step);
    if (key === lastAnswers[k]) continue;
    lastAnswers[k] = key;
    if (!r) continue;
    if (r.ok) { if ($('image-msg').dataset.from === k) { imageMessage(''); } continue; }
    const what = k === 'command' ? state.last_command.op : state.active_step;
    imageMessage(`${what}: ${r.sent === false ? 'NOT SENT' : 'REFUSED'} ${r.code}${r.field ? ' (' + r.field + ')' : ''}: ${r.message}`);
    $('image-msg').dataset.from = k;
  }
}

function updateState() {
  watchdog();
  showRefusalsOnImage();
  const w = state.welcome;
  const st = state.status;
  if (state.source.error) imageMessage('camera: ' + state.source.error);
  updateSteps();
  updateGuidance();
  const lc = state.last_command;
  const cr = $('command-result');
  if (lc) {
    const r = lc.reply;
    cr.className = 'result one ' + (r.ok ? 'ok' : 'refused');
    cr.dataset.ok = String(r.ok);
    cr.textContent = `${lc.op} at ${lc.at || ''}: ` + (r.ok ? 'accepted' : `REFUSED ${r.code}${r.field ? ' (' + r.field + ')' : ''}: ${r.message}`);
  } else { cr.className = 'result one'; cr.textContent = ''; cr.dataset.ok = ''; }
  cr.dataset.op = lc ? lc.op : '';
  updateRecorder();
  for (const name of Object.keys(STEPS)) {
    const stored = !!st && !!st['has_' + name];  // every block is there; the flag says it is stored
    const stale = stored && stepStale(name);
    $('stored-' + name).textContent = stored ? (stale ? 'STALE · ' : '') + describeValues(name, st[name]).split('\n')[0] : '—';
  }
  updateHud();
  render();
}

// ---- The black box: the recorder's state as ajard reports it, and "save the last 5 minutes" -------

function bytes(n) {
  if (n >= 1 << 30) return (n / (1 << 30)).toFixed(2) + ' GiB';
  if (n >= 1 << 20) return (n / (1 << 20)).toFixed(1) + ' MiB';
  if (n >= 1 << 10) return (n / (1 << 10)).toFixed(1) + ' KiB';
  return n + ' B';
}
function updateRecorder() {
  const r = state.recorder && 'known' in state.recorder ? state.recorder : { known: false, why: 'the console has not asked ajard yet' };
  const on = $('rec-on');
  // Never more than ajard said: without its word every field reads "unknown".
  on.textContent = !r.known ? `unknown (${r.why})` : r.on ? 'ON' : `OFF${r.why ? ' (' + r.why + ')' : ''}`;
  on.dataset.state = !r.known ? 'unknown' : r.on ? 'on' : 'off';
  on.title = on.textContent;  // the cell is one line: the whole reason on hover
  $('rec-file').textContent = r.known && r.file ? r.file : r.known ? '—' : 'unknown';
  $('rec-size').textContent = r.known && r.size_bytes !== undefined && r.size_bytes !== null ? bytes(r.size_bytes) : r.known ? '—' : 'unknown';
  // The counts are Status.recorder's (protocol 1.2), as ajard sent them: data-count for tests.
  const c = r.known && r.recorder ? r.recorder : null;
  const drops = $('rec-drops'), written = $('rec-written'), disk = $('rec-disk');
  drops.textContent = c ? `${r.drops} (loop ${c.loop_dropped} of ${c.loop_samples}, I/O ${c.io_dropped} of ${c.io_records})` : r.known ? '—' : 'unknown';
  drops.dataset.count = c ? String(r.drops) : '';
  drops.className = c && r.drops > 0 ? 'bad' : '';
  written.textContent = c ? `${c.records_written} records` + (c.records_lost ? `, ${c.records_lost} lost to the disk (${c.disk_refusals} refusals)` : '') : r.known ? '—' : 'unknown';
  written.dataset.count = c ? String(c.records_written) : '';
  written.dataset.lost = c ? String(c.records_lost) : '';
  disk.textContent = c ? `${bytes(c.directory_bytes)} of the ${bytes(c.max_bytes)} budget, ${bytes(c.saved_bytes)} saved, ${bytes(c.disk_free_bytes)} free` : r.known ? '—' : 'unknown';
  const a = state.recorder_save;
  const el = $('recorder-result');
  if (!a) { el.className = 'result one'; el.textContent = ''; el.dataset.ok = ''; return; }
  if (a.pending) { el.className = 'result one'; el.textContent = `saving the last 5 minutes… (asked at ${a.at})`; el.dataset.ok = 'pending'; return; }
  if (a.reply.ok) {
    const saved = a.saved || [];
    el.className = 'result one ok';
    el.dataset.ok = 'true';
    el.dataset.code = '';
    el.dataset.field = '';
    el.textContent = `saved at ${a.at}: ${saved.length} recording${saved.length === 1 ? '' : 's'}` + (saved.length ? ' — ' + saved.join(', ') : '');
  } else {
    showResult(el, a.reply);
    el.className = 'result one refused';
    el.insertAdjacentText('afterbegin', `save at ${a.at}: `);
  }
}
$('btn-save-recording').addEventListener('click', () => {
  if (!send({ op: 'save_recording' })) { const el = $('recorder-result'); el.className = 'result one refused'; el.dataset.ok = 'false'; el.textContent = 'not sent: no link to the console'; }
});

// ---- Telemetry plots and the log --------------------------------------------------------------------

function updateHud() {
  const t = lastTelemetry;
  let door = 'door: —', warn = '';
  if (t && t.door !== undefined) {
    door = t.door.has_distance ? `door ${t.door.distance_m.toFixed(3)} m` + (t.door.has_yaw ? ` · yaw to square ${deg(t.door.yaw_rad)}` : '') : 'door: no distance yet (measure the width)';
    if (t.staleness.plane) warn = 'PLANE STALE: the base moved: measure the plane again';
    if (t.staleness.contact) warn += (warn ? '\n' : '') + 'CONTACT STALE: set the contact point again';
  }
  const fault = state && state.status && state.status.latched_fault !== 'OK' ? `FAULT ${state.status.latched_fault}: Reset fault first` : '';
  // The active step's picks from before a motion beyond the staleness rule (grey on the image).
  const picks = (state && state.picks[state.active_step]) || [];
  const stalePicks = picks.filter((p) => p.place === 'stale').length;
  if (stalePicks) warn += (warn ? '\n' : '') + `${stalePicks} ${state.active_step} pick${stalePicks > 1 ? 's' : ''} STALE (grey): the base moved: pick again`;
  // The daemon's door guard (docs/protocol.md, Drive): a forward jog near the door is slowed so the
  // base stops at approach_min_standoff_m, and refused there; with a stale plane it is slow.
  const m = (state && state.model) || {};
  const lc = state && state.last_command;
  if (jogHeld === 'fwd' && t) {
    const asked = 0.5 * (m.max_linear_speed_m_s || 0);
    const limited = t.commanded_linear_m_s < asked - 1e-3;
    const atStandoff = lc && lc.op === 'drive' && !lc.reply.ok && lc.reply.code === 'AT_MINIMUM_STANDOFF';
    if (atStandoff || (limited && t.door && t.door.has_distance)) {
      warn += (warn ? '\n' : '') + (t.staleness.plane ? `DOOR GUARD: forward at most ${t.commanded_linear_m_s.toFixed(2)} m/s: the door plane is stale`
        : `DOOR GUARD: forward stops at the minimum standoff ${(m.approach_min_standoff_m || 0).toFixed(2)} m (door ${t.door.distance_m.toFixed(2)} m)`);
    }
    if (atStandoff) warn += '\nAT MINIMUM STANDOFF: back off, turn, or measure the door again';
  }
  if (!live.answering) { door = 'door: unknown (ajard not answering)'; warn = ''; }
  $('hud-door').textContent = door;
  $('hud-warn').textContent = [fault, warn].filter(Boolean).join('\n');
}

function onTelemetry(t) {
  telemetryAt = performance.now();
  lastTelemetry = t;
  samples.push(t);
  if (samples.length > 400) samples.shift();
  // Distance to the door and the yaw still to correct, from the daemon (protocol 1.1, needs a plane).
  if (t.door !== undefined) {
    $('live-door').textContent = t.door.has_distance
      ? `${t.door.distance_m.toFixed(3)} m to the door plane` + (t.door.has_yaw ? `, yaw to square ${deg(t.door.yaw_rad)}` : '') +
        (t.staleness.plane ? '  — plane STALE: measure it again' : '')
      : 'no door plane measured yet';
  }
  $('telemetry-text').textContent = `wheels L ${t.left_wheel_rad.toFixed(3)} R ${t.right_wheel_rad.toFixed(3)} rad · counts ${t.left_counts} / ${t.right_counts} · yaw ${deg(t.base_yaw_odometry_rad)} · ${t.moving ? 'MOVING' : 'still'} · loop ${t.loop.rate_hz.toFixed(0)} Hz, overruns ${t.loop.overruns}`;
  updateHud();
  if (state && samples.length % 4 === 0) updateSteps();
  if (samples.length % 2 === 0) drawPlots();
}
function plot(id, series, colours) {
  const c = $(id), g = c.getContext('2d');
  g.clearRect(0, 0, c.width, c.height);
  let lo = Infinity, hi = -Infinity;
  series.forEach((s) => s.forEach((y) => { lo = Math.min(lo, y); hi = Math.max(hi, y); }));
  if (!isFinite(lo)) return;
  if (hi - lo < 1e-6) { hi += 0.5; lo -= 0.5; }
  series.forEach((s, k) => {
    g.strokeStyle = colours[k]; g.lineWidth = 1.5; g.beginPath();
    s.forEach((y, i) => {
      const x = i * (c.width - 1) / Math.max(1, s.length - 1);
      const py = c.height - 4 - (y - lo) / (hi - lo) * (c.height - 8);
      if (i === 0) g.moveTo(x, py); else g.lineTo(x, py);
    });
    g.stroke();
  });
  g.fillStyle = '#a3acb8'; g.font = '10px sans-serif';
  g.fillText(hi.toFixed(2), 2, 10); g.fillText(lo.toFixed(2), 2, c.height - 2);
}
function drawPlots() {
  plot('plot-wheels', [samples.map((s) => s.left_wheel_rad), samples.map((s) => s.right_wheel_rad)], ['#ffd34d', '#5de0ff']);
  plot('plot-yaw', [samples.map((s) => s.base_yaw_odometry_rad * 180 / Math.PI)], ['#9dff6b']);
  plot('plot-loop', [samples.map((s) => s.loop.period_p99_ns / 1000)], ['#ff8cf0']);
}
function addLog(text) {
  const el = $('log');
  const div = document.createElement('div');
  div.textContent = text;
  if (/refused|FAULT|!!|EMERGENCY|disconnected|OBSERVER|not sent/.test(text)) div.className = 'bad';
  else if (/notice|timeout|stopped/i.test(text)) div.className = 'warn';
  el.appendChild(div);
  while (el.childNodes.length > 300) el.removeChild(el.firstChild);
  el.scrollTop = el.scrollHeight;
}

connect();
render();
watchdog();

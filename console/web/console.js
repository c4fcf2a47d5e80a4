// Ajar operator console: the page. Plain JavaScript, no build step. It draws what ajar-console
// sends over the WebSocket (/ws) and sends the operator's clicks and commands back; every
// measurement and command goes to ajard through ajar-console (docs/console.md lists the messages).
'use strict';

const $ = (id) => document.getElementById(id);
const STEPS = {
  width: { n: 2, colour: '#ffd34d', help: 'Click P1 on the HINGE side edge of the door, then P2 near the MOVING edge, at the same height. Then Send.' },
  handle: { n: 2, colour: '#5de0ff', help: 'Click the handle on its rotation AXIS, then its FREE END. Then Send.' },
  plane: { n: 16, colour: '#9dff6b', help: 'Click three (up to 16) well-spread points on the door leaf, or DRAG A RECTANGLE on the door to pick 16 spread points. Then Send.' },
  contact: { n: 1, colour: '#ff8cf0', help: 'After aligning, click the contact point on the handle. Then Send, then Engage.' },
};

let ws = null;
let state = null;           // the latest "state" snapshot
let colour = null;          // ImageBitmap of the latest colour frame
let depth = null;           // ImageBitmap of the latest depth overlay
let frameSeq = 0;
let imgW = 640, imgH = 480;
let zoom = 1, viewX = 0, viewY = 0;  // the source rectangle's top-left (image pixels)
let drag = null;            // {x0, y0, x1, y1} canvas pixels while the mouse is down
let lastHoverSent = 0;
let pendingHover = null;
let badPick = null;         // {step, index} named by the daemon's refusal
const samples = [];         // telemetry for the plots
const canvas = $('image');
const ctx = canvas.getContext('2d');

function send(obj) {
  if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(obj));
}

// ---- WebSocket -------------------------------------------------------------------------------

function connect() {
  ws = new WebSocket(`ws://${location.host}/ws`);
  ws.binaryType = 'arraybuffer';
  ws.onopen = () => { send({ op: 'alive' }); render(); updateConn(); };
  ws.onclose = () => { updateConn(); setTimeout(connect, 1000); };
  ws.onerror = () => {};
  ws.onmessage = (ev) => {
    if (typeof ev.data !== 'string') return onFrame(ev.data);
    const m = JSON.parse(ev.data);
    if (m.type === 'state') { state = m; updateState(); }
    else if (m.type === 'telemetry') onTelemetry(m);
    else if (m.type === 'log') m.entries.forEach(addLog);
    else if (m.type === 'hover') onHover(m);
    else if (m.type === 'pick_refused') showResult($('result'), { ok: false, code: 'PICK', field: m.field, message: m.message });
    else if (m.type === 'notice') addLog('notice: ' + m.text);
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
    imgW = bitmap.width; imgH = bitmap.height;
    $('frame-info').textContent = `frame ${seq} · ${imgW}×${imgH}`;
  } else {
    if (depth) depth.close();
    depth = bitmap;
  }
  render();
}

// ---- Image region ------------------------------------------------------------------------------

function clampView() {
  const sw = imgW / zoom, sh = imgH / zoom;
  viewX = Math.min(Math.max(0, viewX), imgW - sw);
  viewY = Math.min(Math.max(0, viewY), imgH - sh);
}
// Canvas pixel (CSS) -> image pixel, pixel centres at integers.
function toImage(x, y) {
  const sx = canvas.width / canvas.clientWidth, sy = canvas.height / canvas.clientHeight;
  return { u: viewX + (x * sx) * (imgW / zoom) / canvas.width - 0.5,
           v: viewY + (y * sy) * (imgH / zoom) / canvas.height - 0.5 };
}
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

function render() {
  ctx.imageSmoothingEnabled = zoom < 2;
  ctx.fillStyle = '#000';
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  const sw = imgW / zoom, sh = imgH / zoom;
  if (colour) ctx.drawImage(colour, viewX, viewY, sw, sh, 0, 0, canvas.width, canvas.height);
  if (depth && $('overlay').checked) {
    ctx.globalAlpha = 0.5;
    ctx.drawImage(depth, viewX, viewY, sw, sh, 0, 0, canvas.width, canvas.height);
    ctx.globalAlpha = 1;
  }
  if (!colour) {
    ctx.fillStyle = '#8d96a3'; ctx.font = '16px sans-serif';
    ctx.fillText('waiting for the camera…', 230, 240);
  }
  if (state) {
    for (const [name, step] of Object.entries(STEPS)) {
      const active = state.active_step === name;
      (state.picks[name] || []).forEach((p, i) => {
        const c = toCanvas(p.u, p.v);
        const bad = badPick && badPick.step === name && badPick.index === i;
        ctx.lineWidth = active ? 2.5 : 1.5;
        ctx.strokeStyle = bad ? '#ff3b3b' : step.colour;
        ctx.globalAlpha = active ? 1 : 0.55;
        ctx.beginPath(); ctx.arc(c.x, c.y, bad ? 10 : 7, 0, 2 * Math.PI); ctx.stroke();
        ctx.beginPath(); ctx.moveTo(c.x - 3, c.y); ctx.lineTo(c.x + 3, c.y); ctx.moveTo(c.x, c.y - 3); ctx.lineTo(c.x, c.y + 3); ctx.stroke();
        ctx.font = 'bold 13px sans-serif'; ctx.fillStyle = bad ? '#ff3b3b' : step.colour;
        ctx.fillText(String(i + 1), c.x + 9, c.y - 8);
        ctx.globalAlpha = 1;
      });
    }
  }
  if (drag) {
    ctx.strokeStyle = '#9dff6b'; ctx.setLineDash([6, 4]); ctx.lineWidth = 1.5;
    ctx.strokeRect(drag.x0, drag.y0, drag.x1 - drag.x0, drag.y1 - drag.y0);
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
  $('live-pixel').textContent = `u ${u.toFixed(1)}  v ${v.toFixed(1)}`;
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
  const moved = Math.hypot(d.x1 - d.x0, d.y1 - d.y0);
  const a = toImage(d.x0, d.y0);
  if (moved < 6) {
    if (ev.target === canvas) send({ op: 'pick', u: a.u, v: a.v, seq: frameSeq });
  } else {
    const b = toImage(d.x1, d.y1);
    send({ op: 'rect', u0: a.u, v0: a.v, u1: b.u, v1: b.v, seq: frameSeq });
  }
  render();
});
canvas.addEventListener('wheel', (ev) => {
  ev.preventDefault();
  const p = canvasPoint(ev);
  const { u, v } = toImage(p.x, p.y);
  setZoom(ev.deltaY < 0 ? zoom * 2 : zoom / 2, u, v);
}, { passive: false });
$('zoom-in').onclick = () => setZoom(zoom * 2, viewX + imgW / zoom / 2 - 0.5, viewY + imgH / zoom / 2 - 0.5);
$('zoom-out').onclick = () => setZoom(zoom / 2, viewX + imgW / zoom / 2 - 0.5, viewY + imgH / zoom / 2 - 0.5);
$('overlay').onchange = () => { send({ op: 'overlay', on: $('overlay').checked }); render(); };

// ---- Live data -----------------------------------------------------------------------------------

const fmt = (x, d = 3) => (x === undefined || x === null ? '—' : (x >= 0 ? '+' : '') + x.toFixed(d));
function onHover(m) {
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
const vec = (v) => '(' + v.map((x) => x.toFixed(3)).join(', ') + ')';

function describeValues(step, v) {
  if (!v) return '';
  if (step === 'width') return `width ${v.length_m.toFixed(3)} m, door opens ${v.direction}\nP1 base ${vec(v.p1_base_m)}\nP2 base ${vec(v.p2_base_m)}`;
  if (step === 'handle') return `handle length ${v.length_m.toFixed(3)} m, turns ${v.direction}\naxis base ${vec(v.p1_base_m)}\nend base ${vec(v.p2_base_m)}`;
  if (step === 'plane') return `normal ${vec(v.normal)}\nyaw to square up ${v.yaw_deviation_rad >= 0 ? '+' : ''}${v.yaw_deviation_rad.toFixed(4)} rad (${deg(v.yaw_deviation_rad)})\n` +
    `wheels L ${v.left_wheel_rad.toFixed(3)} rad / R ${v.right_wheel_rad.toFixed(3)} rad = ${v.left_counts} / ${v.right_counts} counts\n` +
    `rms residual ${(v.rms_residual_m * 1000).toFixed(1)} mm, ${v.point_count} points`;
  if (step === 'contact') return `contact base ${vec(v.contact_base_m)}\nreach margin ${v.reach_margin_m.toFixed(3)} m`;
  return JSON.stringify(v);
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
  el.className = 'result ' + (r.ok ? 'ok' : 'refused');
  if (r.ok) {
    el.textContent = describeValues(step, r.values) || ('accepted' + (r.state ? ' → ' + r.state : ''));
    el.dataset.ok = 'true';
    return;
  }
  el.dataset.ok = 'false';
  el.dataset.code = r.code;
  el.dataset.field = r.field || '';
  const field = r.field ? ` <span class="field bad" data-field="${escapeHtml(r.field)}">${escapeHtml(r.field)}</span>` : '';
  el.innerHTML = `REFUSED <b>${escapeHtml(r.code)}</b>${field}\n${escapeHtml(r.message)}`;
}

function updateSteps() {
  const st = state.status || {};
  document.querySelectorAll('#steps button').forEach((b) => {
    const name = b.dataset.step;
    b.classList.toggle('active', name === state.active_step);
    b.classList.toggle('stored', !!st[name]);
  });
  const step = state.active_step;
  $('step-help').textContent = STEPS[step].help;
  const result = state.results[step];
  badPick = null;
  if (result && !result.ok) {
    const i = pickOfField(step, result.field);
    if (i !== null) badPick = { step, index: i };
  }
  const list = $('pick-list');
  list.innerHTML = '';
  (state.picks[step] || []).forEach((p, i) => {
    const li = document.createElement('li');
    li.textContent = `u ${p.u.toFixed(0)} v ${p.v.toFixed(0)}  cam ${vec(p.camera_m)}` + (p.base_m ? `  base ${vec(p.base_m)}` : '') + (p.from_window ? '  (hole: median)' : '');
    if (badPick && badPick.index === i) li.className = 'bad';
    list.appendChild(li);
  });
  const el = $('result');
  if (result) showResult(el, result, step);
  else if (st[step]) { el.className = 'result ok'; el.dataset.ok = 'stored'; el.textContent = 'stored in the daemon:\n' + describeValues(step, st[step]); }
  else { el.className = 'result'; el.dataset.ok = ''; el.textContent = ''; }
}
document.querySelectorAll('#steps button').forEach((b) => { b.onclick = () => send({ op: 'step', step: b.dataset.step }); });
$('btn-send').onclick = () => send({ op: 'send' });
$('btn-undo').onclick = () => send({ op: 'undo' });
$('btn-clear').onclick = () => send({ op: 'clear' });

// ---- Command region --------------------------------------------------------------------------------

// Jog: while a jog button or an arrow key is held the page sends a Drive request every 100 ms (the
// daemon stops the base when they stop coming: the drive command timeout); releasing sends zero.
const JOG = { fwd: [1, 0], back: [-1, 0], left: [0, 1], right: [0, -1] };
const KEY_JOG = { ArrowUp: 'fwd', ArrowDown: 'back', ArrowLeft: 'left', ArrowRight: 'right' };
let jogHeld = null;
function jogStart(dir) {
  if (!state || !state.features.drive || jogHeld === dir) return;
  jogHeld = dir;
  jogSend();
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
  send({ op: 'drive', linear: 0, angular: 0 });
}
setInterval(jogSend, 100);
document.querySelectorAll('[data-jog]').forEach((b) => {
  b.addEventListener('mousedown', () => jogStart(b.dataset.jog));
  b.addEventListener('mouseup', jogStop);
  b.addEventListener('mouseleave', jogStop);
});
window.addEventListener('keyup', (ev) => { if (KEY_JOG[ev.key]) jogStop(); });
window.addEventListener('blur', jogStop);
$('btn-approach').onclick = () => send({ op: 'approach', standoff_m: Number($('standoff').value) });

$('btn-align').onclick = () => send({ op: 'align' });
$('btn-engage').onclick = () => send({ op: 'engage' });
$('btn-stop').onclick = () => send({ op: 'stop' });
$('btn-reset').onclick = () => send({ op: 'reset', clear: false });
$('btn-reset-clear').onclick = () => send({ op: 'reset', clear: true });
$('estop').onclick = () => send({ op: 'estop' });
$('btn-take-over').onclick = () => send({ op: 'take_over' });
window.addEventListener('keydown', (ev) => {
  if (ev.key === 'Escape') { ev.preventDefault(); send({ op: 'estop' }); }
  else if (ev.key === ' ' && ev.target === document.body) { ev.preventDefault(); send({ op: 'stop' }); }
  else if (KEY_JOG[ev.key] && ev.target === document.body) { ev.preventDefault(); jogStart(KEY_JOG[ev.key]); }
});

function updateConn() {
  const el = $('conn');
  const page = ws && ws.readyState === WebSocket.OPEN;
  const daemon = page && state && state.connection.connected;
  el.className = 'pill ' + (daemon ? 'ok' : page ? 'partial' : '');
  $('conn-text').textContent = !page ? 'console unreachable' : daemon ? `ajard ${state.connection.daemon}` + (state.welcome && state.welcome.driver_kind ? ` (${state.welcome.driver_kind})` : '') : `ajard: ${state ? state.connection.message : '…'}`;
}

function updateState() {
  updateConn();
  const w = state.welcome;
  const st = state.status;
  $('role').textContent = w ? w.role : '—';
  $('btn-take-over').hidden = !(w && w.role === 'observer');
  $('state').textContent = st ? st.state : '—';
  const fault = st ? st.latched_fault : 'OK';
  $('fault').textContent = fault === 'OK' ? 'none' : fault;
  $('fault-box').classList.toggle('latched', fault !== 'OK');
  $('deadman-text').textContent = state.connection.heartbeat ? 'fed by this page' : 'not fed';
  // Approach and jog need protocol 1.1 and the daemon's driving support.
  $('drive-box').hidden = !(w && w.version_minor >= 1 && state.features.drive);
  const se = $('source-error');
  se.hidden = !state.source.error;
  se.textContent = state.source.error ? 'camera: ' + state.source.error : '';
  updateSteps();
  if (state.last_command) showResult($('command-result'), Object.assign({}, state.last_command.reply, { values: null, state: state.last_command.reply.state }), state.last_command.op);
  $('command-result').dataset.op = state.last_command ? state.last_command.op : '';
  for (const name of Object.keys(STEPS)) {
    $('stored-' + name).textContent = st && st[name] ? describeValues(name, st[name]).split('\n')[0] : '—';
  }
  render();
}

// ---- Telemetry plots and the log --------------------------------------------------------------------

function onTelemetry(t) {
  samples.push(t);
  if (samples.length > 400) samples.shift();
  if (state && state.status) state.status.state = t.state;
  $('state').textContent = t.state;
  // Distance to the door and the yaw still to correct, from the daemon (protocol 1.1, needs a plane).
  if (t.door_has_distance !== undefined) {
    $('live-door').textContent = t.door_has_distance
      ? `${t.door_distance_m.toFixed(3)} m to the door plane` + (t.door_has_yaw ? `, yaw to square ${deg(t.door_yaw_rad)}` : '') +
        (t.plane_stale ? '  — plane STALE: measure it again' : '')
      : 'no door plane measured yet';
  }
  $('telemetry-text').textContent = `wheels L ${t.left_wheel_rad.toFixed(3)} R ${t.right_wheel_rad.toFixed(3)} rad · counts ${t.left_counts} / ${t.right_counts} · yaw ${deg(t.base_yaw_odometry_rad)} · ${t.moving ? 'MOVING' : 'still'} · loop ${t.loop.rate_hz.toFixed(0)} Hz, overruns ${t.loop.overruns}`;
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
  g.fillStyle = '#8d96a3'; g.font = '10px sans-serif';
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
  if (/refused|fault|!!|EMERGENCY|disconnected/i.test(text)) div.className = 'bad';
  else if (/notice|timeout/i.test(text)) div.className = 'warn';
  el.appendChild(div);
  while (el.childNodes.length > 300) el.removeChild(el.firstChild);
  el.scrollTop = el.scrollHeight;
}

connect();
render();

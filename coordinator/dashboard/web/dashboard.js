// The vcmfarm dashboard: polls the coordinator's JSON (docs/PROTOCOL.md, "Dashboard") and
// draws it. No framework: a few DOM helpers, and the plots as SVG paths.
// The farm key is read from the input when signing in, used by WebCrypto for one HMAC and
// dropped; only the session token it earns is kept, in this page's memory.
'use strict';

const POLL_MS = 2000, JOB_POLL_MS = 3000;
const state = { status: null, job: null, selected: null, token: null, tokenExpires: 0, lastPreview: 0,
  noticeFromPoll: false };
const $ = (id) => document.getElementById(id);

function el(tag, attrs, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === 'class') e.className = v; else if (k.startsWith('on')) e.addEventListener(k.slice(2), v); else e.setAttribute(k, v);
  }
  for (const c of children) e.append(c instanceof Node ? c : document.createTextNode(c == null ? '' : String(c)));
  return e;
}

const num = (v, digits = 3) => v == null ? '–' : (Math.abs(v) >= 1000 || (v !== 0 && Math.abs(v) < 0.001)) ? v.toExponential(2) : v.toPrecision(digits);
function duration(s) {
  if (s == null) return '–';
  if (s < 60) return s.toFixed(1) + ' s';
  if (s < 3600) return Math.floor(s / 60) + 'm' + String(Math.round(s % 60)).padStart(2, '0') + 's';
  return Math.floor(s / 3600) + 'h' + String(Math.floor((s % 3600) / 60)).padStart(2, '0') + 'm';
}
function stopText(j) {
  const s = j.stop || {}, parts = [];
  if (s.iterations != null) parts.push(s.iterations + ' it');
  if (s.time != null) parts.push(duration(s.time));
  if (s.target_rmse != null) parts.push('RMSE ' + s.target_rmse);
  if (s.target_error != null) parts.push('error ' + s.target_error);
  return parts.join(' or ') + (j.progress_by ? ' (' + j.progress_by + ')' : '');
}
// One line of notice for two speakers: the poll loop (the coordinator does not answer) and
// the person's own actions (signing in). The poll clears only a notice it put up itself, so
// an answer to the person stays until their next action, not until the next poll.
function notice(text, fromPoll = false) {
  const n = $('notice');
  n.textContent = text || '';
  n.hidden = !text;
  state.noticeFromPoll = fromPoll && !!text;
}

async function getJSON(url) {
  const r = await fetch(url, { cache: 'no-store' });
  if (!r.ok) throw new Error(url + ': ' + r.status);
  return r.json();
}

// ---- the farm, the jobs, the workers, the events ----

function renderFarm(st) {
  const busy = st.workers_busy, total = st.workers.filter((w) => w.state !== 'left' && w.state !== 'lost').length;
  $('farm').textContent = `${num(st.iterations_per_second)} it/s · ${busy} of ${total} workers busy · ` +
    `${st.jobs.length} jobs · coordinator ${st.coordinator.version || ''} (protocol ${st.coordinator.protocol})`;
}

/* What a job's estimated RMSE covers (status JSON: resolved.estimate_covers): the error for
 * the unbiased algorithms, the variance alone for vcm, ppm and bpm, whose merging bias no
 * estimate sees. */
function estimateNote(j) {
  return j.resolved && j.resolved.estimate_covers === 'variance' && j.estimated_rmse != null ? ' (variance only)' : '';
}
function estimateTitle(j) {
  const covers = j.resolved && j.resolved.estimate_covers;
  return covers ? { title: 'the estimate covers the ' + covers } : {};
}

function renderJobs(st) {
  const rows = st.jobs.map((j) => {
    const bar = el('div', { class: 'bar' }, el('div', { class: 'fill state-' + j.state }));
    bar.firstChild.style.width = (100 * Math.min(1, j.progress || 0)).toFixed(1) + '%';
    bar.title = (100 * (j.progress || 0)).toFixed(1) + '%';
    const tr = el('tr', { class: 'job' + (j.id === state.selected ? ' selected' : ''), 'data-job': j.id,
      onclick: () => select(j.id) },
      el('td', {}, j.id), el('td', {}, j.name), el('td', { class: 'state-' + j.state }, j.state),
      el('td', {}, bar, el('span', { class: 'pct' }, (100 * (j.progress || 0)).toFixed(0) + '%')),
      el('td', {}, num(j.iterations_per_second)), el('td', {}, num(j.rmse)), el('td', estimateTitle(j), num(j.estimated_rmse) + estimateNote(j)),
      el('td', {}, j.state === 'running' || j.state === 'queued' ? duration(j.eta_seconds) : '–'),
      el('td', {}, stopText(j)), el('td', {}, j.priority), el('td', { class: 'requires' }, (j.requires || []).join(', ') || '–'));
    return tr;
  });
  $('job-rows').replaceChildren(...rows);
  if (rows.length === 0) $('job-rows').append(el('tr', {}, el('td', { colspan: 11, class: 'dim' }, 'no jobs: vcmfarm submit …')));
}

function renderWorkers(st) {
  const rows = st.workers.map((w) => el('tr', { class: 'worker' },
    el('td', {}, w.name), el('td', {}, (w.host || '') + (w.cores ? ` (${w.cores} cores)` : '')),
    el('td', { class: 'state-' + w.state }, w.state), el('td', { class: 'tags' }, (w.tags || []).join(', ') || '–'),
    el('td', {}, w.lease ? `job ${w.lease.job} [${w.lease.begin}, ${w.lease.end})` : '–'),
    el('td', {}, num(w.iterations_per_second)), el('td', {}, duration(w.last_seen_seconds) + ' ago'),
    el('td', {}, w.totals.iterations_merged), el('td', {}, w.totals.results_refused)));
  $('worker-rows').replaceChildren(...rows);
  if (rows.length === 0) $('worker-rows').append(el('tr', {}, el('td', { colspan: 9, class: 'dim' }, 'no workers: vcmfarm worker …')));
}

// What happened to jobs (submitted, pilot done, done, failed, cancelled, paused, resumed,
// priority changed) apart from what happened to workers and leases; the latest first in each.
const JOB_EVENTS = new Set(['job_submitted', 'pilot_done', 'job_done', 'job_failed', 'job_cancelled', 'job_paused', 'job_resumed',
  'priority_changed']);
function eventItem(e) {
  return el('li', { class: 'event', 'data-kind': e.kind },
    el('time', {}, new Date(e.time * 1000).toLocaleTimeString()), ' ', el('b', {}, e.kind), ' ',
    e.job ? `job ${e.job} ` : '', e.worker ? `(${e.worker}) ` : '', e.message);
}
function renderEvents(ev) {
  const jobs = ev.events.filter((e) => JOB_EVENTS.has(e.kind)).slice(0, 30).map(eventItem);
  const others = ev.events.filter((e) => !JOB_EVENTS.has(e.kind)).slice(0, 30).map(eventItem);
  $('job-event-list').replaceChildren(...jobs);
  if (jobs.length === 0) $('job-event-list').append(el('li', { class: 'dim' }, 'no job has been submitted yet'));
  $('event-list').replaceChildren(...others);
  if (others.length === 0) $('event-list').append(el('li', { class: 'dim' }, 'nothing has happened yet'));
}

async function poll() {
  try {
    const st = await getJSON('/api/status');
    state.status = st;
    renderFarm(st); renderJobs(st); renderWorkers(st);
    if (state.selected == null && st.jobs.length) select(st.jobs[st.jobs.length - 1].id);
    else if (state.selected != null && !st.jobs.some((j) => j.id === state.selected)) select(null);
    renderEvents(await getJSON('/api/events'));
    if (state.noticeFromPoll) notice('');
  } catch (e) {
    notice('The coordinator does not answer (' + e.message + '); trying again.', true);
  }
}

// ---- one job: facts, ranges, plots, preview ----

function select(id) {
  state.selected = id;
  state.job = null;
  $('job').hidden = id == null;
  document.querySelectorAll('tr.job').forEach((tr) => tr.classList.toggle('selected', Number(tr.dataset.job) === id));
  if (id != null) { pollJob(); refreshPreview(true); }
}

function renderJob(j) {
  $('job-title').textContent = `Job ${j.id}: ${j.name} (${j.state})`;
  const facts = [['scene', j.scene.name], ['algorithm', j.resolved ? j.resolved.algorithm : ''],
    ['size', j.resolved ? `${j.resolved.width}×${j.resolved.height}` : ''],
    ['iterations', `${j.iterations_done} done, ${j.iterations_leased} leased`],
    // a job with a pilot (docs/PROTOCOL.md, "Pilots"): its progress, then the allocation
    ['pilot', !j.pilot ? 'none' : j.pilot.allocation ? `${j.pilot.iterations} iterations done; ${j.pilot.allocation}`
      : `${j.pilot.iterations_done}/${j.pilot.iterations} iterations`],
    ['running', duration(j.seconds)],
    ['stops at', stopText(j)], ['stop reason', j.stop_message || j.stop_reason || '–'],
    ['refused results', j.results_refused], ['non-finite samples', j.nonfinite_samples ?? '–'],
    ['merged with bias', j.biased_merges ? `${j.biased_merges} light vertices (upg's policy: the estimate omits their bias)` : '0'],
    ['requires', (j.requires || []).join(', ') || 'any worker'],
    ['settings', j.settings || '']];
  $('job-facts').replaceChildren(...facts.flatMap(([k, v]) => [el('dt', {}, k), el('dd', {}, v)]));
  if (document.activeElement !== $('priority')) $('priority').value = j.priority;
  $('pause').disabled = j.paused || !(j.state === 'running' || j.state === 'queued');
  $('resume').disabled = !j.paused || j.state !== 'paused';
  const workers = (state.status ? state.status.workers : []).filter((w) => w.lease && w.lease.job === j.id);
  const rows = workers.map((w) => el('tr', {}, el('td', {}, w.name), el('td', {}, `[${w.lease.begin}, ${w.lease.end})`),
    el('td', {}, w.state), el('td', {}, num(w.iterations_per_second))));
  $('job-ranges').replaceChildren(...rows);
  if (!rows.length) $('job-ranges').append(el('tr', {}, el('td', { colspan: 4, class: 'dim' }, 'no worker holds a lease of this job')));
  const log = j.convergence || [];
  const series = (key, x) => log.filter((e) => e[key] != null && e[x] > 0).map((e) => [e[x], e[key]]);
  const lines = [{ name: 'estimated RMSE', cls: 'est', points: null, key: 'estimated_rmse' },
    { name: 'RMSE vs reference', cls: 'ref', points: null, key: 'rmse' }];
  plot($('plot-time'), lines.map((l) => ({ ...l, points: series(l.key, 'wall_seconds') })), 'render seconds (sum over workers)');
  plot($('plot-iterations'), lines.map((l) => ({ ...l, points: series(l.key, 'iterations') })), 'iterations');
}

async function pollJob() {
  const id = state.selected;
  if (id == null) return;
  try {
    const doc = await getJSON('/api/jobs/' + id);
    if (state.selected !== id || !doc.jobs.length) return;
    state.job = doc.jobs[0];
    renderJob(state.job);
  } catch (e) { /* the next poll tries again */ }
}

const SVG = 'http://www.w3.org/2000/svg';
function svg(tag, attrs, text) {
  const e = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (text != null) e.textContent = text;
  return e;
}

// A tick's label: plain digits where they are short (0.05, 20, 1500), else 2e-4, 3e+5.
function tickLabel(v) {
  return v >= 1e-3 && v < 1e5 ? String(Number(v.toPrecision(2))) : v.toExponential(0);
}
// Ticks of a log axis over [10^lo, 10^hi]: 1, 2 and 5 times the decades inside, thinned to
// the decades when there are more than `most`; never fewer than two (the axis's ends, when
// it spans less than a step), so that every axis has numbers to read it by.
function logTicks(lo, hi, most) {
  const all = [];
  for (let d = Math.floor(lo); d <= Math.ceil(hi); d++)
    for (const m of [1, 2, 5]) {
      const v = m * 10 ** d, l = Math.log10(v);
      if (l >= lo - 1e-9 && l <= hi + 1e-9) all.push({ v, m });
    }
  let ticks = all.length > most ? all.filter((t) => t.m === 1) : all;
  if (ticks.length > most) ticks = ticks.filter((_, i) => i % Math.ceil(ticks.length / most) === 0);
  if (ticks.length < 2) ticks = [{ v: 10 ** lo }, { v: 10 ** hi }];
  return ticks.map((t) => t.v);
}

// Log-log axes over every series' points; one path per series; numbered ticks on both axes.
function plot(target, lines, xlabel) {
  const W = 420, H = 220, L = 56, R = 10, T = 12, B = 38;
  const all = lines.flatMap((l) => l.points).filter(([x, y]) => x > 0 && y > 0);
  const nodes = [];
  if (all.length < 1) {
    nodes.push(svg('text', { x: W / 2, y: H / 2, 'text-anchor': 'middle', class: 'dim' }, 'no convergence log yet'));
    target.replaceChildren(...nodes);
    return;
  }
  const lx = all.map(([x]) => Math.log10(x)), ly = all.map(([, y]) => Math.log10(y));
  let [x0, x1, y0, y1] = [Math.min(...lx), Math.max(...lx), Math.min(...ly), Math.max(...ly)];
  if (x1 - x0 < 0.3) { x0 -= 0.15; x1 += 0.15; }
  if (y1 - y0 < 0.3) { y0 -= 0.15; y1 += 0.15; }
  const px = (x) => L + (Math.log10(x) - x0) / (x1 - x0) * (W - L - R);
  const py = (y) => T + (y1 - Math.log10(y)) / (y1 - y0) * (H - T - B);
  nodes.push(svg('rect', { x: L, y: T, width: W - L - R, height: H - T - B, class: 'frame' }));
  for (const v of logTicks(x0, x1, 7)) {
    const x = px(v);
    nodes.push(svg('line', { x1: x, x2: x, y1: T, y2: H - B, class: 'grid' }));
    nodes.push(svg('line', { x1: x, x2: x, y1: H - B, y2: H - B + 4, class: 'tick' }));
    nodes.push(svg('text', { x, y: H - B + 14, 'text-anchor': 'middle', class: 'tick-x' }, tickLabel(v)));
  }
  for (const v of logTicks(y0, y1, 6)) {
    const y = py(v);
    nodes.push(svg('line', { x1: L, x2: W - R, y1: y, y2: y, class: 'grid' }));
    nodes.push(svg('line', { x1: L - 4, x2: L, y1: y, y2: y, class: 'tick' }));
    nodes.push(svg('text', { x: L - 6, y: y + 4, 'text-anchor': 'end', class: 'tick-y' }, tickLabel(v)));
  }
  nodes.push(svg('text', { x: L + (W - L - R) / 2, y: H - 6, 'text-anchor': 'middle' }, xlabel));
  nodes.push(svg('text', { x: 12, y: T + (H - T - B) / 2, 'text-anchor': 'middle', transform: `rotate(-90 12 ${T + (H - T - B) / 2})` }, 'error'));
  let legend = 0;
  for (const l of lines) {
    const pts = l.points.filter(([x, y]) => x > 0 && y > 0);
    if (!pts.length) continue;
    const d = pts.map(([x, y], i) => (i ? 'L' : 'M') + px(x).toFixed(1) + ' ' + py(y).toFixed(1)).join(' ');
    nodes.push(svg('path', { d, class: 'line ' + l.cls }));
    for (const [x, y] of pts.slice(-1)) nodes.push(svg('circle', { cx: px(x), cy: py(y), r: 2.5, class: 'dot ' + l.cls }));
    nodes.push(svg('text', { x: W - R - 4, y: T + 14 + 14 * legend++, 'text-anchor': 'end', class: 'legend ' + l.cls }, l.name));
  }
  target.replaceChildren(...nodes);
}

async function refreshPreview(force) {
  const id = state.selected;
  if (id == null || (!force && Date.now() - state.lastPreview < JOB_POLL_MS - 100)) return;
  state.lastPreview = Date.now();
  const exposure = $('exposure').value;
  try {
    const r = await fetch(`/api/jobs/${id}/preview.png?exposure=${exposure}&t=${Date.now()}`, { cache: 'no-store' });
    if (state.selected !== id) return;
    if (!r.ok) { $('preview-info').textContent = (await r.json()).error; return; }
    const url = URL.createObjectURL(await r.blob()), img = $('preview'), old = img.src;
    img.onload = () => { if (old.startsWith('blob:')) URL.revokeObjectURL(old); };
    img.src = url;
    $('preview-info').textContent = state.job ? `${state.job.iterations_done} iterations, as of the latest checkpoint` : '';
  } catch (e) { /* the next refresh tries again */ }
}

// ---- signing in and acting ----

function hex(bytes) { return Array.from(new Uint8Array(bytes), (b) => b.toString(16).padStart(2, '0')).join(''); }
function unhex(text) { return new Uint8Array(text.match(/../g).map((h) => parseInt(h, 16))); }

async function post(url, body, withToken) {
  const headers = { 'Content-Type': 'application/json' };
  if (withToken && state.token) headers['X-Vcmfarm-Session'] = state.token;
  return fetch(url, { method: 'POST', headers, body: body ? JSON.stringify(body) : '{}', cache: 'no-store' });
}

async function signIn(event) {
  event.preventDefault();
  const input = $('key'), text = input.value.trim();
  input.value = '';
  if (!/^[0-9a-fA-F]{64}$/.test(text)) return notice('A farm key is 64 hexadecimal digits: the content of the key file (vcmfarm keygen).');
  if (!window.crypto || !crypto.subtle) return notice('This browser offers no WebCrypto here: open the dashboard at http://127.0.0.1 (an ssh tunnel) or through HTTPS to sign in.');
  try {
    const key = await crypto.subtle.importKey('raw', unhex(text), { name: 'HMAC', hash: 'SHA-256' }, false, ['sign']);
    const { nonce } = await (await post('/api/session/nonce')).json();
    const proof = hex(await crypto.subtle.sign('HMAC', key, new TextEncoder().encode('vcmfarm-dashboard-session:' + nonce)));
    const r = await post('/api/session', { nonce, proof });
    const answer = await r.json();
    if (!r.ok) return notice('Not signed in: ' + answer.error);
    state.token = answer.token;
    state.tokenExpires = Date.now() + answer.expires_in * 1000;
    showSession();
    notice('');
  } catch (e) { notice('Not signed in: ' + e.message); }
}

function showSession() {
  const live = state.token && Date.now() < state.tokenExpires;
  if (!live) state.token = null;
  $('sign-in').hidden = !!live;
  $('signed-in').hidden = !live;
  if (live) $('session-info').textContent = `signed in, ${Math.round((state.tokenExpires - Date.now()) / 60000)} min left`;
}

async function signOut() {
  if (state.token) await post('/api/session/close', null, true).catch(() => {});
  state.token = null;
  showSession();
}

async function act(verb, body) {
  const id = state.selected, result = $('action-result');
  if (id == null) return;
  if (!state.token) { result.textContent = 'Sign in with the farm key first.'; return null; }
  const r = await post(`/api/jobs/${id}/${verb}`, body, true);
  if (r.status === 401 || r.status === 403) { state.token = null; showSession(); }
  return r;
}

async function simple(verb, body) {
  const r = await act(verb, body);
  if (!r) return;
  const answer = await r.json();
  $('action-result').textContent = r.ok ? `${verb}: ${answer.message}` : `${verb} refused: ${answer.error}`;
  poll();
  pollJob();
}

async function download(verb, name) {
  const r = await act(verb, null);
  if (!r) return;
  if (!r.ok) { $('action-result').textContent = `${verb} refused: ${(await r.json()).error}`; return; }
  const url = URL.createObjectURL(await r.blob());
  const a = el('a', { href: url, download: name });
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 10000);
  $('action-result').textContent = `${name} downloaded`;
}

document.addEventListener('DOMContentLoaded', () => {
  $('sign-in').addEventListener('submit', signIn);
  $('sign-out').addEventListener('click', signOut);
  $('pause').addEventListener('click', () => simple('pause'));
  $('resume').addEventListener('click', () => simple('resume'));
  $('cancel').addEventListener('click', () => simple('cancel'));
  $('remove').addEventListener('click', () => {
    // Removing deletes the job's film and files on the coordinator: asked first, every time.
    const j = state.job, id = state.selected;
    if (id == null) return;
    const what = j ? `job ${id} (${j.name}, ${j.state}, ${j.iterations_done} iterations)` : `job ${id}`;
    if (!window.confirm(`Remove ${what}? The coordinator deletes its film, scene and the files no other job ` +
      'uses; this cannot be undone. Fetch the film first if you need it.')) {
      $('action-result').textContent = `remove: job ${id} kept`;
      return;
    }
    simple('remove');
  });
  $('set-priority').addEventListener('click', () => simple('priority', { priority: Number($('priority').value) }));
  $('download-film').addEventListener('click', () => download('film', `job-${state.selected}.exr`));
  $('download-image').addEventListener('click', () =>
    download(`image?exposure=${$('exposure').value}`, `job-${state.selected}.png`));
  $('exposure').addEventListener('input', () => { $('exposure-value').textContent = $('exposure').value; refreshPreview(true); });
  poll();
  setInterval(poll, POLL_MS);
  setInterval(() => { pollJob(); refreshPreview(false); showSession(); }, JOB_POLL_MS);
});

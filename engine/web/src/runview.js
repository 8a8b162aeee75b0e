// One run, live or finished: its status, where each step ran, its times, what moved to whom,
// check values and conditions, warnings and failures in words, a chart of bytes moved, and
// downloads. A RunView belongs to one run id: a new run gets a new view (no mixing).

import { el, fill, round, bytes, ms, saveBlob } from './dom.js';
import { followEvents, getJson, request } from './api.js';
import { bytesChart } from './chart.js';

export const FORMATS = ['ply', 'obj', 'off', 'stl', 'mfm'];
const STEP_COLUMNS = ['#', 'step', 'service', 'host', 'compute', 'queue', 'overhead', 'transfer / apply', 'mesh', 'correction vs full', 'sent', 'value', ''];
const FINAL = new Set(['completed', 'failed', 'cancelled', 'interrupted']);
/** Events that change a part of the record the view patches in place. */
const PATCHES = {
  status: (record, data) => Object.assign(record, data),
  input: (record, data) => { record.input = data; },
  broadcast: (record, data) => { record.broadcast = data; },
  result: (record, data) => { record.result = data; },
  settled: (record, data) => Object.assign(record, data),
  warning: (record, data) => { record.warnings.push(data); },
  step: (record, data) => { record.steps[data.index] = data; },
  transfer: (record, data) => { record.steps[data.step]?.transfers.push(data.transfer); },
  correction: (record, data) => {
    const step = record.steps[data.step];
    if (step) Object.assign(step, { correction_bytes: data.correction_bytes, correction_estimated: false, correction_estimate_bytes: data.estimate_bytes });
  },
  condition: (record, data) => { if (record.steps[data.step]) record.steps[data.step].condition = data.condition; },
  prefetch: (record, data) => {
    record.prefetches ??= [];
    for (const plugin of data.plugins) {
      const at = record.prefetches.findIndex((p) => p.host === plugin.host && p.plugin === plugin.plugin && p.outcome === 'pending');
      if (at >= 0) record.prefetches[at] = plugin;
      else record.prefetches.push(plugin);
    }
  },
};

/** Downloads `path` with the token and saves it under the engine's file name. */
export async function download(path) {
  const response = await request(path);
  const disposition = response.headers.get('Content-Disposition') ?? '';
  const name = /filename="([^"]+)"/.exec(disposition)?.[1] ?? 'mesh';
  saveBlob(await response.blob(), name);
  const notKept = response.headers.get('x-meshflow-not-kept');
  return notKept ? `${name}, without ${notKept} (download PLY or MFM to keep them)` : name;
}

export class RunView {
  /** `show(label, path)` puts a mesh (a `?format=raw` path) into the viewer; `input(path)`
   *  tells it where the run's input is (for "Before"); `nameOf(url)` is the name an input
   *  URL was uploaded under, if known, so errors name the user's file. */
  constructor(root, id, { show, input = () => {}, nameOf = () => null }) {
    this.root = root;
    this.id = id;
    this.show = show;
    this.input = input;
    this.nameOf = nameOf;
    this.abort = new AbortController();
    this.record = null;
    this.shownResult = false;
    fill(root, el('p', { testid: 'run-status', className: 'status' }, `run ${id}: connecting…`));
  }

  close() {
    this.abort.abort();
  }

  /** Follows the run's events until the stream ends; reconnects once if it breaks early. */
  async follow() {
    for (let attempt = 0; attempt < 3; attempt += 1) {
      try {
        await followEvents(this.id, (kind, data) => this.event(kind, data), this.abort.signal);
        if (this.record && FINAL.has(this.record.status)) return;
      } catch (error) {
        if (this.abort.signal.aborted) return;
        this.problem(error.message);
      }
      if (this.abort.signal.aborted) return;
      await new Promise((resolve) => setTimeout(resolve, 1000));
    }
    // The stream keeps breaking: read the record as it is.
    try {
      this.event('record', await getJson(`/runs/${encodeURIComponent(this.id)}`));
    } catch (error) {
      this.problem(error.message);
    }
  }

  /** Events apply in the order they came: a whole-record read must not overwrite the
   *  steps that arrived while it was on its way. */
  event(kind, data) {
    // A failed read is said, and the chain goes on with the next event.
    this.applied = (this.applied ?? Promise.resolve())
      .then(() => this.apply(kind, data))
      .catch((error) => this.problem(error.message));
    return this.applied;
  }

  async apply(kind, data) {
    if (this.abort.signal.aborted) return;
    if (kind === 'record') this.record = data;
    else if (this.record && PATCHES[kind]) PATCHES[kind](this.record, data);
    else {
      // A restart or resume rewrote the record, or an event this view does not know:
      // read it whole.
      this.record = await getJson(`/runs/${encodeURIComponent(this.id)}`);
    }
    this.draw();
  }

  problem(message) {
    const status = this.root.querySelector('[data-testid=run-status]');
    if (status) status.textContent = `run ${this.id}: ${message}`;
  }

  draw() {
    const r = this.record;
    const steps = r.steps.filter(Boolean);
    const status = el('p', { testid: 'run-status', className: `status ${r.status}`, 'data-status': r.status, 'data-run': r.id }, statusLine(r));
    const running = r.status === 'running' && steps.length ? `now after ${steps.at(-1).path} on ${steps.at(-1).host}` : '';
    fill(this.root,
      status,
      running && el('p', { className: 'note' }, running),
      r.error && el('p', { className: 'error', testid: 'run-error' }, plainError(this.named(r.error))),
      r.warnings.length > 0 && el('ul', { className: 'warnings', testid: 'run-warnings' }, r.warnings.map((w) => el('li', {}, w))),
      r.input && el('p', {}, `Input: ${r.input.vertices.toLocaleString('en')} vertices, ${r.input.triangles.toLocaleString('en')} triangles `,
        el('button', { testid: 'show-input', onclick: () => this.show('input', this.path('input')) }, 'view input')),
      // What the file held beyond the mesh, which neither the steps nor the result keep.
      r.input?.not_kept?.length > 0 && el('ul', { className: 'warnings', testid: 'input-not-kept' },
        r.input.not_kept.map((what) => el('li', {}, `Not kept from the input file: ${what}`))),
      r.input?.attributes?.length > 0 && el('p', { className: 'note', testid: 'input-attributes' },
        `The input carries ${r.input.attributes.join(', ')}.`),
      r.broadcast && el('p', { className: 'note' }, `Input loaded on ${r.broadcast.hosts.length} host(s) in ${ms(r.broadcast.ms)}: `,
        r.broadcast.hosts.map((h) => `${h.host} (${bytes(h.bytes)}, ${ms(h.download_ms)} download, ${ms(h.load_ms)} load)`).join('; ')),
      this.stepTable(steps),
      steps.some((s) => s.kind === 'filter') && el('div', { className: 'chart' }, el('h4', {}, `Bytes moved per step (transfer: ${r.transfer})`), bytesChart(steps)),
      r.result && this.resultBar(r));
    if (r.input) this.input(this.path('input'));
    if (r.status === 'completed' && r.result && !this.shownResult) {
      this.shownResult = true;
      this.show('result', this.path('result'));
    }
  }

  /** An error with each uploaded input's URL replaced by the file's name. */
  named(error) {
    return error.replace(/\bhttps?:\/\/[^\s"]*\/inputs\/[0-9a-f]+(\.[a-z0-9]+)?/gi, (url) => {
      const name = this.nameOf(url);
      return name ? `"${name}"` : url;
    });
  }

  path(which) {
    return `/runs/${encodeURIComponent(this.id)}/${which}`;
  }

  resultBar(r) {
    const note = el('span', { className: 'note', testid: 'download-note' });
    const get = async (format) => {
      try {
        note.textContent = `saved ${await download(`${this.path('result')}?format=${format}`)}`;
      } catch (error) {
        note.textContent = error.message;
      }
    };
    // The last filter's output is the result; a run of checks only gives back its input.
    const last = r.steps.filter((s) => s && s.kind === 'filter').at(-1);
    const carried = (last ? last.attributes : r.input?.attributes) ?? [];
    return el('div', { className: 'result' },
      `Result: ${r.result.vertices.toLocaleString('en')} vertices, ${r.result.triangles.toLocaleString('en')} triangles, hash ${r.result.hash.slice(0, 12)}… `,
      carried.length > 0 && el('span', { className: 'note', testid: 'result-attributes' }, `carries ${carried.join(', ')} `),
      el('button', { testid: 'show-result', onclick: () => this.show('result', this.path('result')) }, 'view result'),
      ' Download: ', FORMATS.map((f) => el('button', { testid: `download-${f}`, onclick: () => get(f) }, f.toUpperCase())),
      ' ', note);
  }

  stepTable(steps) {
    if (!steps.length) return el('p', { className: 'note' }, 'No step has finished yet.');
    return el('table', { className: 'steps' },
      el('thead', {}, el('tr', {}, STEP_COLUMNS.map((h) => el('th', {}, h)))),
      el('tbody', {}, steps.map((s) => this.stepRow(s))));
  }

  stepRow(s) {
    const transferMs = s.transfers.reduce((sum, t) => sum + t.download_ms, 0);
    const applyMs = s.transfers.reduce((sum, t) => sum + t.apply_ms, 0);
    const sent = s.transfers.map((t) =>
      `→ ${t.host}: ${t.via} ${bytes(t.bytes)}${t.fallback ? ` (fell back: ${t.fallback})` : ''}${t.error ? ` (failed: ${t.error})` : ''}`);
    const value = s.kind === 'check'
      ? [round(s.value), s.condition === null || s.condition === undefined ? '' : s.condition ? ' ✓ condition held' : ' ✗ condition did not hold']
      : '';
    const actions = s.kind === 'filter' && el('span', {},
      el('button', { testid: 'show-step', onclick: () => this.show(`step ${s.index}`, this.path(`steps/${s.index}/output`)) }, 'view'),
      stepDownload(this.path(`steps/${s.index}/output`)));
    const cells = [
      el('td', { className: 'index' }, s.index), el('td', { className: 'path' }, el('code', {}, s.path)),
      el('td', { className: 'service', title: s.report }, s.service),
      el('td', {}, s.host, s.failed_hosts.length ? ` (after ${s.failed_hosts.join(', ')} failed)` : ''),
      el('td', {}, ms(s.compute_ms)), el('td', {}, ms(s.wait_ms)), el('td', {}, ms(s.overhead_ms)),
      el('td', {}, s.transfers.length ? `${ms(transferMs)} / ${ms(applyMs)}` : '—'),
      el('td', {}, s.vertices != null ? `${s.vertices.toLocaleString('en')} v, ${s.triangles.toLocaleString('en')} t` : ''),
      el('td', {}, s.kind === 'filter' ? `${s.correction_estimated ? '≈ ' : ''}${bytes(s.correction_bytes)} vs ${bytes(s.full_bytes)}` : ''),
      el('td', { className: 'sent' }, sent.length ? sent.map((line) => el('div', {}, line)) : '—'),
      el('td', { testid: 'step-value' }, value),
      el('td', { className: 'actions' }, actions)];
    // Each cell names its column: on a narrow screen a row is a card of labelled cells.
    cells.forEach((cell, i) => cell.setAttribute('data-label', STEP_COLUMNS[i]));
    return el('tr', { testid: 'step-row', className: s.kind, 'data-path': s.path }, cells);
  }
}

function stepDownload(path) {
  const format = el('select', {}, FORMATS.map((f) => el('option', { value: f }, f)));
  const note = el('span', { className: 'note' });
  return el('span', {}, ' ', format, el('button', {
    testid: 'download-step',
    onclick: async () => {
      try {
        note.textContent = `saved ${await download(`${path}?format=${format.value}`)}`;
      } catch (error) {
        note.textContent = error.message;
      }
    },
  }, 'download'), note);
}

function statusLine(r) {
  const total = r.total_ms ? ` in ${ms(r.total_ms)}` : '';
  const words = {
    queued: 'queued: waiting for a run slot',
    running: 'running',
    completed: `completed${total}`,
    failed: `failed${total}`,
    cancelled: `cancelled${total}`,
    interrupted: 'interrupted by an engine restart',
  };
  return `run ${r.id}: ${words[r.status] ?? r.status}`;
}

/** The engine's error, with a plain-words lead for the failures users meet most. */
function plainError(error) {
  const leads = [
    [/cannot connect|unreachable|connection refused/i, 'A host or the input could not be reached.'],
    [/does not load|not a mesh|parse|decode|garbage|truncated/i, 'The input is not a mesh the hosts can read.'],
    [/plugin-failed|trapped|fuel|deadline/i, 'A plugin failed while running.'],
  ];
  const lead = leads.find(([pattern]) => pattern.test(error))?.[1];
  return lead ? `${lead} ${error}` : `The run failed: ${error}`;
}

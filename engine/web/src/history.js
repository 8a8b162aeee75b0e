// Run history: every run the engine keeps (they survive its restarts), newest first; open
// one, run it again (same or another input), or compare two runs' records side by side.

import { el, fill, round, bytes, ms } from './dom.js';
import { getJson } from './api.js';
import { bytesChart } from './chart.js';

export class History {
  /** `open(id)` shows a run; `rerun(submission)` loads its workflow and input for a new run. */
  constructor(root, { open, rerun }) {
    this.root = root;
    this.open = open;
    this.rerun = rerun;
    this.picked = new Set();
    this.list = el('div', {});
    this.comparison = el('div', { testid: 'comparison' });
    fill(root,
      el('div', { className: 'toolbar' },
        el('button', { testid: 'history-refresh', onclick: () => this.refresh() }, 'Refresh'),
        el('button', { testid: 'history-compare', onclick: () => this.compare() }, 'Compare the two ticked runs')),
      this.list, this.comparison);
  }

  async refresh() {
    let runs;
    try {
      runs = await getJson('/runs');
    } catch (error) {
      fill(this.list, el('p', { className: 'error' }, error.message));
      return;
    }
    runs.reverse();
    fill(this.list, runs.length === 0 ? el('p', { className: 'note' }, 'No runs yet.') : el('table', { className: 'history' },
      el('thead', {}, el('tr', {}, ['', 'run', 'status', 'steps', ''].map((h) => el('th', {}, h)))),
      el('tbody', {}, runs.map((run) => {
        const tick = el('input', { type: 'checkbox', checked: this.picked.has(run.id),
          onchange: () => (tick.checked ? this.picked.add(run.id) : this.picked.delete(run.id)) });
        return el('tr', { testid: 'history-row', 'data-run': run.id, 'data-status': run.status },
          el('td', {}, tick), el('td', {}, el('code', {}, run.id)),
          el('td', { className: `status ${run.status}` }, run.status), el('td', {}, run.steps),
          el('td', {},
            el('button', { testid: 'history-open', onclick: () => this.open(run.id) }, 'open'),
            el('button', { testid: 'history-rerun', onclick: () => this.again(run.id) }, 're-run…')));
      }))));
  }

  async again(id) {
    try {
      this.rerun(await getJson(`/runs/${encodeURIComponent(id)}/workflow`));
    } catch (error) {
      fill(this.comparison, el('p', { className: 'error' }, error.message));
    }
  }

  async compare() {
    const ids = [...this.picked].slice(-2);
    if (ids.length !== 2) {
      fill(this.comparison, el('p', { className: 'error' }, 'Tick two runs to compare them.'));
      return;
    }
    try {
      const records = await Promise.all(ids.map((id) => getJson(`/runs/${encodeURIComponent(id)}`)));
      fill(this.comparison, compareTable(records), el('div', { className: 'side-by-side' },
        records.map((r) => el('div', {}, el('h4', {}, `${r.id} (transfer: ${r.transfer})`), bytesChart(r.steps)))));
    } catch (error) {
      fill(this.comparison, el('p', { className: 'error' }, error.message));
    }
  }
}

const sent = (r) => r.steps.reduce((sum, s) => sum + s.transfers.reduce((n, t) => n + t.bytes, 0), 0);

function compareTable([a, b]) {
  const rows = [
    ['status', (r) => r.status],
    ['transfer mode', (r) => r.transfer],
    ['total time', (r) => ms(r.total_ms)],
    ['steps executed', (r) => r.steps.length],
    ['compute (sum)', (r) => ms(r.steps.reduce((sum, s) => sum + s.compute_ms, 0))],
    ['bytes sent between hosts', (r) => bytes(sent(r))],
    ['result', (r) => (r.result ? `${r.result.vertices} v, hash ${r.result.hash.slice(0, 12)}…` : r.error ?? '—')],
  ];
  const longest = Math.max(a.steps.length, b.steps.length);
  for (let i = 0; i < longest; i += 1) {
    rows.push([`step ${i}`, (r) => {
      const s = r.steps[i];
      if (!s) return '—';
      return s.kind === 'check' ? `${s.path} ${s.service} = ${round(s.value)}` : `${s.path} ${s.service} ${ms(s.compute_ms)}, sent ${bytes(s.transfers.reduce((n, t) => n + t.bytes, 0))}`;
    }]);
  }
  return el('table', { className: 'compare' },
    el('thead', {}, el('tr', {}, el('th', {}, ''), el('th', {}, a.id), el('th', {}, b.id))),
    el('tbody', {}, rows.map(([label, of]) => {
      const [x, y] = [String(of(a)), String(of(b))];
      return el('tr', { className: x === y ? '' : 'differs' }, el('th', {}, label), el('td', {}, x), el('td', {}, y));
    })));
}

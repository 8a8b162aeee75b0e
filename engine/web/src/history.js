// Run history: every run the engine keeps (they survive its restarts), newest first, with
// when, who, which input, what workflow and how long (`GET /history`); filtered by text;
// open one, run it again (same or another input), or compare two runs' records side by side.

import { el, fill, round, bytes, ms } from './dom.js';
import { getJson } from './api.js';
import { bytesChart } from './chart.js';

export class History {
  /** `open(id)` shows a run; `rerun(submission)` loads its workflow and input for a new run;
   *  `named(url, name)` is told the name each uploaded input was given. */
  constructor(root, { open, rerun, named = () => {} }) {
    this.root = root;
    this.open = open;
    this.rerun = rerun;
    this.named = named;
    this.picked = new Set();
    this.list = el('div', { className: 'scroll-x' });
    this.comparison = el('div', { testid: 'comparison', className: 'scroll-x' });
    this.filter = el('input', { type: 'search', testid: 'history-filter', placeholder: 'filter: input, service, user, status…',
      'aria-label': 'filter runs', oninput: () => this.applyFilter() });
    fill(root,
      el('div', { className: 'toolbar' },
        this.filter,
        el('button', { testid: 'history-refresh', onclick: () => this.refresh() }, 'Refresh'),
        el('button', { testid: 'history-compare', onclick: () => this.compare() }, 'Compare the two ticked runs')),
      this.list, this.comparison);
  }

  async refresh() {
    let runs;
    try {
      runs = await getJson('/history');
    } catch (error) {
      fill(this.list, el('p', { className: 'error' }, error.message));
      return;
    }
    runs.reverse();
    const withUsers = new Set(runs.map((run) => run.user)).size > 1 || runs.some((run) => run.user !== 'default');
    const head = ['', 'when', 'input', 'workflow', 'status', 'steps', 'took', withUsers && 'who', 'run', ''].filter((h) => h !== false);
    fill(this.list, runs.length === 0 ? el('p', { className: 'note' }, 'No runs yet.') : el('table', { className: 'history' },
      el('thead', {}, el('tr', {}, head.map((h) => el('th', {}, h)))),
      el('tbody', {}, runs.map((run) => {
        if (run.input_name) this.named(run.input, run.input_name);
        const tick = el('input', { type: 'checkbox', checked: this.picked.has(run.id), 'aria-label': `pick run ${run.id} to compare`,
          onchange: () => (tick.checked ? this.picked.add(run.id) : this.picked.delete(run.id)) });
        const input = run.input_name ?? (run.input.split('/').pop() || run.input);
        const cells = [
          el('td', {}, tick),
          el('td', { className: 'when', title: run.created_unix ? new Date(run.created_unix * 1000).toISOString() : '' }, when(run.created_unix)),
          el('td', { className: 'input', title: run.input }, input),
          el('td', { className: 'workflow' }, summary(run.workflow)),
          el('td', { className: `status ${run.status}` }, run.status),
          el('td', {}, run.steps),
          el('td', {}, ms(run.total_ms)),
          withUsers && el('td', { className: 'user' }, run.user),
          el('td', {}, el('code', {}, run.id)),
          el('td', { className: 'actions' },
            el('button', { testid: 'history-open', onclick: () => this.open(run.id) }, 'open'),
            el('button', { testid: 'history-rerun', onclick: () => this.again(run.id) }, 're-run…'))].filter(Boolean);
        cells.forEach((cell, i) => cell.setAttribute('data-label', head[i]));
        return el('tr', { testid: 'history-row', 'data-run': run.id, 'data-status': run.status }, cells);
      }))));
    this.applyFilter();
  }

  /** Hides the rows whose text does not hold every word of the filter. */
  applyFilter() {
    const words = this.filter.value.toLowerCase().split(/\s+/).filter(Boolean);
    for (const row of this.list.querySelectorAll('[data-testid=history-row]')) {
      const text = row.textContent.toLowerCase();
      row.hidden = !words.every((word) => text.includes(word));
    }
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

/** "14:03:12" today, else "2025-03-01 14:03". */
function when(unix) {
  if (!unix) return '—';
  const date = new Date(unix * 1000);
  const pad = (n) => String(n).padStart(2, '0');
  const time = `${pad(date.getHours())}:${pad(date.getMinutes())}`;
  if (date.toDateString() === new Date().toDateString()) return `${time}:${pad(date.getSeconds())}`;
  return `${date.getFullYear()}-${pad(date.getMonth() + 1)}-${pad(date.getDate())} ${time}`;
}

/** A workflow in one line: its services in order, IF and WHILE with their checks. */
export function summary(workflow) {
  const list = (steps) => (Array.isArray(steps) ? steps.map(step).join(' → ') : '?');
  const step = (s) => {
    if (typeof s?.run === 'string') return s.run;
    if (s?.if) return `IF ${s.if.check} [${list(s.then)}${s.else?.length ? ` | else ${list(s.else)}` : ''}]`;
    if (s?.while) return `WHILE ${s.while.check} [${list(s.do)}]`;
    return '?';
  };
  const text = list(workflow?.steps);
  return text.length > 160 ? `${text.slice(0, 159)}…` : text || '(no steps)';
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

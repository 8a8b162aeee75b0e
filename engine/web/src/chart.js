// The bytes each step moved, as an SVG bar chart: the correction and the full mesh a filter
// produced, and what was actually sent to other hosts (whichever of the two each took).

import { bytes } from './dom.js';

const SVG = 'http://www.w3.org/2000/svg';
const SERIES = [
  // null: not known (a full mesh is measured only when it was packed to be sent).
  { key: 'correction', colour: '#3b82f6', of: (s) => s.correction_bytes ?? null },
  { key: 'full mesh', colour: '#9ca3af', of: (s) => s.full_bytes ?? null },
  { key: 'sent', colour: '#f59e0b', of: (s) => s.transfers.reduce((sum, t) => sum + t.bytes, 0) },
];
// A bar per series, each tall enough for its 10 px label, so labels never overlap.
const BAR = 12;
const ROW = SERIES.length * BAR + 10;
const LABEL = 190;
const WIDTH = 640;

function svg(tag, attributes, text) {
  const node = document.createElementNS(SVG, tag);
  for (const [key, value] of Object.entries(attributes)) node.setAttribute(key, String(value));
  if (text !== undefined) node.textContent = text;
  return node;
}

export function bytesChart(steps) {
  const filters = steps.filter((s) => s.kind === 'filter');
  const most = Math.max(1, ...filters.flatMap((s) => SERIES.map((series) => series.of(s))));
  const height = filters.length * ROW + 24;
  const chart = svg('svg', { width: WIDTH, height, viewBox: `0 0 ${WIDTH} ${height}`, 'data-testid': 'bytes-chart', role: 'img',
    'aria-label': 'bytes moved per step' });
  filters.forEach((step, row) => {
    const y = row * ROW;
    chart.append(svg('text', { x: 0, y: y + ROW / 2 + 4, 'font-size': 11 }, `${step.index} ${step.service}`));
    SERIES.forEach((series, i) => {
      const value = series.of(step);
      const width = ((WIDTH - LABEL - 80) * (value ?? 0)) / most;
      const label = value === null ? `${series.key} not measured` : bytes(value);
      const bar = svg('rect', { x: LABEL, y: y + i * BAR, width: Math.max(width, 1), height: BAR - 1, fill: series.colour });
      bar.append(svg('title', {}, `${series.key}: ${label}`));
      const text = svg('text', { x: LABEL + width + 4, y: y + i * BAR + BAR - 2, 'font-size': 10, fill: value === null ? '#64748b' : '#1f2937' }, label);
      if (value === null) text.setAttribute('font-style', 'italic');
      chart.append(bar, text);
    });
  });
  SERIES.forEach((series, i) => {
    const x = LABEL + i * 110;
    chart.append(svg('rect', { x, y: height - 14, width: 10, height: 10, fill: series.colour }),
      svg('text', { x: x + 14, y: height - 5, 'font-size': 11 }, series.key));
  });
  return chart;
}

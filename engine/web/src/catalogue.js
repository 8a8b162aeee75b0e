// The service catalogue: every service with its kind, doc, parameters (type, default,
// range, choices, doc), result type, and the hosts that offer it.

import { el, fill } from './dom.js';

function range(param) {
  if (param.min === undefined && param.max === undefined) return '';
  return `[${param.min ?? '−∞'}, ${param.max ?? '∞'}]`;
}

export function drawCatalogue(root, services) {
  fill(root, services.length === 0
    ? el('p', { className: 'note' }, 'No host offers any service yet.')
    : services.map((s) => el('section', { className: 'service', 'data-service': s.name },
      el('h4', {}, s.name, ' ', el('span', { className: `kind ${s.kind}` }, s.kind),
        s.result_type ? el('span', { className: 'note' }, ` → ${s.result_type}`) : ''),
      el('p', { className: 'doc' }, s.doc),
      s.params.length
        ? el('table', { className: 'param-table' },
          el('thead', {}, el('tr', {}, ['parameter', 'type', 'default', 'range', 'choices', 'doc'].map((h) => el('th', {}, h)))),
          el('tbody', {}, s.params.map((p) => el('tr', {},
            el('td', {}, el('code', {}, p.name)), el('td', {}, p.type), el('td', {}, JSON.stringify(p.default)),
            el('td', {}, range(p)), el('td', {}, (p.choices ?? []).join(', ')), el('td', {}, p.doc)))))
        : el('p', { className: 'note' }, 'No parameters.'),
      el('p', { className: 'note' }, `Offered by ${s.hosts.length} host(s): ${s.hosts.join(', ')}`),
      el('p', { className: 'note', testid: 'service-plugins' },
        `Plugin digest(s): ${(s.plugins ?? []).map((digest) => digest.slice(0, 16) + '…').join(', ')}`))));
}

// Plugin upload: a `.wasm` to a chosen host, through the engine (hosts are other origins),
// with the host's upload token; then what the host now offers.

import { el, fill } from './dom.js';
import { request } from './api.js';

export class Plugins {
  constructor(root, { uploaded }) {
    this.root = root;
    this.host = el('select', { testid: 'plugin-host' });
    this.token = el('input', { type: 'password', testid: 'plugin-token', placeholder: 'upload token', autocomplete: 'off' });
    this.file = el('input', { type: 'file', accept: '.wasm', testid: 'plugin-file' });
    this.answer = el('div', { testid: 'plugin-answer' });
    this.hosts = el('div', {});
    this.uploaded = uploaded;
    fill(root,
      el('div', { className: 'toolbar' },
        el('label', {}, 'Host ', this.host), el('label', {}, 'Token ', this.token),
        el('label', {}, 'Component ', this.file),
        el('button', { testid: 'plugin-upload', onclick: () => this.upload() }, 'Upload')),
      this.answer, el('h3', {}, 'Hosts'), this.hosts);
  }

  drawHosts(hosts) {
    const chosen = this.host.value;
    fill(this.host, hosts.map((h) => el('option', { value: h.url, selected: h.url === chosen }, h.url)));
    fill(this.hosts, el('table', {},
      el('thead', {}, el('tr', {}, ['host', 'state', 'running', 'services'].map((h) => el('th', {}, h)))),
      el('tbody', {}, hosts.map((h) => el('tr', { testid: 'host-row' },
        el('td', {}, h.url), el('td', { className: h.up ? 'ok' : 'error' }, h.up ? 'up' : `down${h.last_error ? `: ${h.last_error}` : ''}`),
        el('td', {}, h.running), el('td', {}, h.services.join(', ')))))));
  }

  async upload() {
    const file = this.file.files[0];
    if (!file) return fill(this.answer, el('p', { className: 'error' }, 'Choose a .wasm file first.'));
    fill(this.answer, el('p', { className: 'note' }, `uploading ${file.name}…`));
    try {
      const response = await request(`/plugins?host=${encodeURIComponent(this.host.value)}`, {
        method: 'POST',
        headers: { 'X-Upload-Token': this.token.value, 'Content-Type': 'application/wasm' },
        body: file,
      });
      const body = await response.json();
      const lead = body.present?.length
        ? `${this.host.value} has ${file.name} already (plugin ${body.digest.slice(0, 16)}…, the same bytes): nothing changed. It offers:`
        : `${this.host.value} took ${file.name} (plugin ${body.digest.slice(0, 16)}…), offering:`;
      fill(this.answer, el('p', { className: 'ok' }, lead),
        el('ul', {}, body.services.map((s) => el('li', {}, el('b', {}, s.name), ` (${s.kind}): ${s.doc}`))));
      this.uploaded();
    } catch (error) {
      fill(this.answer, el('p', { className: 'error' }, `Upload failed: ${error.message}`));
    }
  }
}

// The workflow builder. The workflow JSON object is the one source of truth: the step cards
// are drawn from it and edit it in place, the JSON view shows it, and an edit of the JSON
// view that parses replaces it and redraws the cards. Every change is validated by the
// engine itself (`POST /workflows/validate`), whose error names the step path.

import { el, fill, saveBlob } from './dom.js';
import { postJson } from './api.js';
import repair from '../../../examples/workflows/repair.json';
import branch from '../../../examples/workflows/branch-on-manifold.json';
import smooth from '../../../examples/workflows/smooth-while-unstable.json';

export const EXAMPLES = {
  'repair.json': repair,
  'branch-on-manifold.json': branch,
  'smooth-while-unstable.json': smooth,
};
const OPS = ['<', '<=', '==', '!=', '>=', '>'];
const TRANSFERS = ['auto', 'correction', 'replay', 'full'];
/** How the engine picks hosts; `link` (the default) weighs measured links and load. */
const PLACEMENTS = ['link', 'load'];
/** The step picker's first choice: common and harmless (it never removes what matters). */
const FIRST_CHOICES = ['remove-smallest-components', 'laplacian-smoothing'];
/** Quiet time after the last keystroke before asking the engine to validate. */
const VALIDATE_DELAY_MS = 250;

export class Builder {
  /** `catalogue()` gives the services by name (from `GET /services`). */
  constructor(root, catalogue) {
    this.catalogue = catalogue;
    this.workflow = { steps: [], transfer: 'auto' };
    this.cards = el('div', { className: 'cards' });
    this.json = el('textarea', {
      testid: 'workflow-json',
      spellcheck: false,
      oninput: () => this.jsonEdited(),
    });
    this.jsonNote = el('div', { className: 'note', testid: 'json-note' });
    this.validation = el('div', { className: 'validation', testid: 'validation' });
    this.transfer = el('select', { testid: 'transfer', onchange: () => this.set('transfer', this.transfer.value) },
      TRANSFERS.map((mode) => el('option', { value: mode }, mode)));
    // Both optional keys leave the workflow when set back to their default.
    this.quantize = el('input', { type: 'number', min: 1, max: 24, step: 1, placeholder: 'off', testid: 'quantize',
      oninput: () => this.setOptional('quantize', this.quantize.value === '' ? undefined : Number(this.quantize.value)) });
    this.placement = el('select', { testid: 'placement',
      onchange: () => this.setOptional('placement', this.placement.value === 'link' ? undefined : this.placement.value) },
      PLACEMENTS.map((mode) => el('option', { value: mode }, mode)));
    const file = el('input', { type: 'file', accept: '.json,application/json', testid: 'workflow-file',
      onchange: () => file.files[0] && this.loadFile(file.files[0]) });
    fill(root,
      el('div', { className: 'toolbar' },
        el('label', {}, 'Load a workflow file ', file),
        el('button', { testid: 'save-workflow', onclick: () => this.save() }, 'Save workflow…'),
        el('span', { className: 'examples' }, 'Examples: ',
          Object.keys(EXAMPLES).map((name) =>
            el('button', { testid: `example-${name.replace('.json', '')}`, onclick: () => this.load(structuredClone(EXAMPLES[name])) }, name))),
        el('button', { testid: 'clear-workflow', onclick: () => this.load({ steps: [], transfer: 'auto' }) }, 'Clear')),
      el('div', { className: 'builder-panes' },
        el('div', { className: 'pane' }, el('h3', {}, 'Steps'), this.cards,
          el('div', { className: 'run-options' },
            el('label', {}, 'Transfer ', this.transfer),
            el('label', { title: 'Keep every step on a grid of this many bits per coordinate (1–24); empty: off' }, 'Quantize (bits) ', this.quantize),
            el('label', { title: 'link: weigh measured links and load; load: tasks in flight only' }, 'Placement ', this.placement))),
        el('div', { className: 'pane' }, el('h3', {}, 'JSON'), this.json, this.jsonNote)),
      this.validation);
    this.load(this.workflow);
  }

  /** Replaces the workflow (from a file, an example, history) and redraws everything. */
  load(workflow) {
    this.workflow = workflow;
    this.redraw();
  }

  async loadFile(file) {
    try {
      this.load(JSON.parse(await file.text()));
      this.jsonNote.textContent = `loaded ${file.name}`;
    } catch (error) {
      this.jsonNote.textContent = `${file.name} is not a workflow: ${error.message}`;
    }
  }

  save() {
    saveBlob(new Blob([this.text()], { type: 'application/json' }), 'workflow.json');
  }

  text() {
    return JSON.stringify(this.workflow, null, 2);
  }

  set(key, value) {
    this.workflow[key] = value;
    this.changed();
  }

  /** Sets `key`, or removes it for `undefined` (the engine's default). */
  setOptional(key, value) {
    if (value === undefined) delete this.workflow[key];
    else this.workflow[key] = value;
    this.changed();
  }

  /** After an edit of the cards: the JSON view follows, the engine validates. */
  changed() {
    this.json.value = this.text();
    this.jsonNote.textContent = '';
    this.validateSoon();
  }

  redraw() {
    this.drawCards();
    this.changed();
  }

  drawCards() {
    const steps = Array.isArray(this.workflow.steps) ? this.workflow.steps : null;
    this.transfer.value = this.workflow.transfer ?? 'auto';
    this.quantize.value = this.workflow.quantize ?? '';
    this.placement.value = this.workflow.placement ?? 'link';
    fill(this.cards, steps ? this.stepList(steps, 'steps', true) : el('p', { className: 'error' }, '"steps" is not a list: edit the JSON'));
  }

  jsonEdited() {
    try {
      this.workflow = JSON.parse(this.json.value);
    } catch (error) {
      this.jsonNote.textContent = `not JSON yet: ${error.message}`;
      return;
    }
    this.jsonNote.textContent = '';
    this.drawCards();
    this.validateSoon();
  }

  validateSoon() {
    clearTimeout(this.validateTimer);
    // An empty workflow is where everyone starts: said plainly, not as an error.
    if (Array.isArray(this.workflow.steps) && this.workflow.steps.length === 0) {
      this.cards.querySelectorAll('.invalid').forEach((card) => card.classList.remove('invalid'));
      this.validation.className = 'validation empty';
      this.validation.textContent = 'Add a step to begin: a workflow needs at least one step.';
      return;
    }
    // No verdict of an earlier version stays on show.
    this.validation.className = 'validation pending';
    this.validation.textContent = 'Checking with the engine…';
    this.validateTimer = setTimeout(() => this.validate(), VALIDATE_DELAY_MS);
  }

  /** Asks the engine; marks the card the error's path points into. */
  async validate() {
    const asked = this.text();
    let problem = null;
    try {
      await postJson('/workflows/validate', { workflow: this.workflow });
    } catch (error) {
      problem = error;
    }
    if (asked !== this.text()) return; // Edited meanwhile: a newer answer is coming.
    this.cards.querySelectorAll('.invalid').forEach((card) => card.classList.remove('invalid'));
    if (!problem) {
      this.validation.className = 'validation ok';
      this.validation.textContent = 'The engine accepts this workflow.';
      return;
    }
    this.validation.className = 'validation error';
    this.validation.textContent = problem.kind === 'http' ? `Not valid: ${problem.message}` : problem.message;
    const path = problem.message.split(':')[0];
    const cards = [...this.cards.querySelectorAll('[data-path]')].filter((card) =>
      path === card.dataset.path || path.startsWith(`${card.dataset.path}.`) || path.startsWith(`${card.dataset.path}[`));
    cards.at(-1)?.classList.add('invalid');
  }

  services(kind) {
    return Object.values(this.catalogue()).filter((s) => s.kind === kind).map((s) => s.name).sort();
  }

  /** A list of steps with its add bar; `top` marks the workflow's own list (testids). */
  stepList(steps, path, top) {
    const filters = this.services('filter');
    const chosen = [this.lastService, ...FIRST_CHOICES].find((name) => filters.includes(name)) ?? filters[0];
    const serviceSelect = el('select', { testid: top ? 'add-step-service' : undefined, 'aria-label': 'service of the step to add',
      onchange: () => { this.lastService = serviceSelect.value; } },
      filters.map((name) => el('option', { value: name, selected: name === chosen }, name)));
    const add = (step) => {
      steps.push(step);
      this.redraw();
      // Focus goes to the new step, so keyboard users carry on there.
      const card = this.cards.querySelector(`[data-path="${CSS.escape(`${path}[${steps.length - 1}]`)}"]`);
      (card?.querySelector('select, input, button') ?? card)?.focus();
    };
    const checks = this.services('check');
    const condition = () => this.defaultCondition(checks[0]);
    return el('div', { className: 'step-list' },
      steps.map((step, index) => this.card(steps, index, `${path}[${index}]`)),
      el('div', { className: 'add-bar' },
        serviceSelect,
        el('button', { testid: top ? 'add-step' : undefined,
          onclick: () => { this.lastService = serviceSelect.value; add({ run: serviceSelect.value }); } }, '+ step'),
        el('button', { testid: top ? 'add-if' : undefined, disabled: !checks.length,
          onclick: () => add({ if: condition(), then: [], else: [] }) }, '+ IF'),
        el('button', { testid: top ? 'add-while' : undefined, disabled: !checks.length,
          onclick: () => add({ while: condition(), 'max-iterations': 10, do: [] }) }, '+ WHILE')));
  }

  defaultCondition(check) {
    const boolean = this.catalogue()[check]?.result_type === 'boolean';
    return { check, op: boolean ? '==' : '>', value: boolean ? true : 0 };
  }

  card(steps, index, path) {
    const step = steps[index];
    const move = (by) => {
      const [moved] = steps.splice(index, 1);
      steps.splice(index + by, 0, moved);
      this.redraw();
    };
    const tools = el('span', { className: 'tools' },
      el('button', { title: 'move up', testid: 'step-up', disabled: index === 0, onclick: () => move(-1) }, '↑'),
      el('button', { title: 'move down', testid: 'step-down', disabled: index === steps.length - 1, onclick: () => move(1) }, '↓'),
      el('button', { title: 'remove', testid: 'step-remove', onclick: () => { steps.splice(index, 1); this.redraw(); } }, '✕'));
    const card = el('div', { className: 'card', testid: 'step-card', 'data-path': path, tabIndex: -1 });
    if (step && typeof step.run === 'string') {
      const select = el('select', { onchange: () => { step.run = select.value; delete step.params; this.redraw(); } },
        this.services('filter').map((name) => el('option', { value: name, selected: name === step.run }, name)));
      if (!this.catalogue()[step.run]) select.prepend(el('option', { value: step.run, selected: true }, `${step.run} (not offered)`));
      fill(card, el('div', { className: 'card-head' }, el('code', {}, path), ' run ', select, tools),
        this.paramForm(step, step.run));
    } else if (step && step.if) {
      step.then ??= [];
      fill(card, el('div', { className: 'card-head' }, el('code', {}, path), ' IF ', tools),
        this.conditionForm(step.if),
        el('div', { className: 'branch' }, el('b', {}, 'then'), this.stepList(step.then, `${path}.then`, false)),
        el('div', { className: 'branch' }, el('b', {}, 'else'), this.stepList(step.else ??= [], `${path}.else`, false)));
    } else if (step && step.while) {
      step.do ??= [];
      const max = el('input', { type: 'number', min: 0, step: 1, value: step['max-iterations'] ?? '', placeholder: '100',
        oninput: () => { if (max.value === '') delete step['max-iterations']; else step['max-iterations'] = Number(max.value); this.changed(); } });
      fill(card, el('div', { className: 'card-head' }, el('code', {}, path), ' WHILE ', tools),
        this.conditionForm(step.while),
        el('label', {}, 'max iterations ', max),
        el('div', { className: 'branch' }, el('b', {}, 'do'), this.stepList(step.do, `${path}.do`, false)));
    } else {
      fill(card, el('div', { className: 'card-head' }, el('code', {}, path), ' (not a step the builder knows: edit the JSON) ', tools));
    }
    return card;
  }

  conditionForm(condition) {
    const check = el('select', { onchange: () => { Object.assign(condition, this.defaultCondition(check.value)); delete condition.params; this.redraw(); } },
      this.services('check').map((name) => el('option', { value: name, selected: name === condition.check }, name)));
    const op = el('select', { onchange: () => { condition.op = op.value; this.changed(); } },
      OPS.map((o) => el('option', { value: o, selected: o === condition.op }, o)));
    const type = this.catalogue()[condition.check]?.result_type;
    const value = type === 'boolean'
      ? el('select', { onchange: () => { condition.value = value.value === 'true'; this.changed(); } },
        ['true', 'false'].map((v) => el('option', { value: v, selected: String(condition.value) === v }, v)))
      : el('input', { type: type === 'text' ? 'text' : 'number', value: condition.value ?? '', step: 'any',
        oninput: () => { condition.value = type === 'text' ? value.value : Number(value.value); this.changed(); } });
    return el('div', { className: 'condition' }, 'check ', check, ' ', op, ' ', value, this.paramForm(condition, condition.check));
  }

  /** One field per parameter of `service`; a field left at its default is left out. */
  paramForm(owner, service) {
    const info = this.catalogue()[service];
    if (!info || !info.params.length) return el('div', { className: 'params empty' }, info ? 'no parameters' : '');
    return el('div', { className: 'params' }, info.params.map((param) => {
      const current = owner.params?.[param.name];
      const store = (value) => {
        owner.params ??= {};
        if (value === undefined) delete owner.params[param.name];
        else owner.params[param.name] = value;
        if (!Object.keys(owner.params).length) delete owner.params;
        this.changed();
      };
      let field;
      if (param.type === 'boolean') {
        field = el('input', { type: 'checkbox', checked: current ?? param.default, onchange: () => store(field.checked) });
      } else if (param.choices) {
        field = el('select', { onchange: () => store(field.value) },
          param.choices.map((choice) => el('option', { value: choice, selected: choice === (current ?? param.default) }, choice)));
      } else if (param.type === 'integer' || param.type === 'real') {
        field = el('input', { type: 'number', step: param.type === 'integer' ? 1 : 'any', min: param.min ?? '', max: param.max ?? '',
          placeholder: String(param.default), value: current ?? '',
          oninput: () => store(field.value === '' ? undefined : Number(field.value)) });
      } else {
        field = el('input', { type: 'text', placeholder: String(param.default), value: current ?? '',
          oninput: () => store(field.value === '' ? undefined : field.value) });
      }
      field.dataset.param = param.name;
      return el('label', { className: 'param', title: param.doc }, `${param.name} `, field);
    }));
  }
}

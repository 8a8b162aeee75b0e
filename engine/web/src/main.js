// The workbench page: tabs for building and running, the catalogue, history and plugins;
// the login form when the engine asks for a token; a banner when the engine is unreachable.

import './style.css';
import { el, fill } from './dom.js';
import { getJson, postJson, uploadInput, onUnauthorized, takeTokenFromFragment, token } from './api.js';
import { Builder } from './builder.js';
import { drawCatalogue } from './catalogue.js';
import { RunView } from './runview.js';
import { Viewer } from './viewer.js';
import { History } from './history.js';
import { Plugins } from './plugins.js';

/** How often hosts and services are read again (new plugins, hosts going down). */
const POLL_MS = 5000;

takeTokenFromFragment();

let services = {};
const banner = el('div', { className: 'banner', testid: 'engine-banner', hidden: true });
const tabs = {};
const panels = {};
const tabBar = el('nav', { className: 'tabs' });
for (const [name, label] of [['build', 'Build & run'], ['catalogue', 'Catalogue'], ['history', 'History'], ['plugins', 'Plugins']]) {
  tabs[name] = el('button', { testid: `tab-${name}`, onclick: () => showTab(name) }, label);
  panels[name] = el('section', { className: 'panel', hidden: true });
  tabBar.append(tabs[name]);
}
function showTab(name) {
  for (const key of Object.keys(tabs)) {
    panels[key].hidden = key !== name;
    tabs[key].classList.toggle('active', key === name);
  }
  if (name === 'history') history.refresh();
}

// Login: asked for on a 401 (the engine runs with --api-token).
const tokenField = el('input', { type: 'password', testid: 'login-token', placeholder: 'API token', autocomplete: 'off' });
const login = el('form', { className: 'login', testid: 'login', hidden: true,
  onsubmit: (event) => { event.preventDefault(); token.set(tokenField.value.trim()); login.hidden = true; refresh(); showUser(); } },
el('p', {}, 'This engine needs an API token (the one `meshflow up` printed, or its `--api-token`).'),
tokenField, el('button', { type: 'submit', testid: 'login-submit' }, 'Sign in'));
onUnauthorized(() => { login.hidden = false; });

// Who is signed in (`GET /me`): a user sees their own runs, an admin everyone's.
const signedIn = el('span', { className: 'signed-in', testid: 'signed-in-user' });
async function showUser() {
  try {
    const me = await getJson('/me');
    signedIn.textContent = `${me.name}${me.role === 'admin' ? ' (admin)' : ''}`;
    signedIn.dataset.user = me.name;
  } catch {
    signedIn.textContent = '';
    delete signedIn.dataset.user;
  }
}

// Build & run.
const builderRoot = el('div', {});
const catalogueRoot = el('div', { testid: 'service-list' });
const builder = new Builder(builderRoot, () => services);
const meshFile = el('input', {
  type: 'file', testid: 'mesh-file', multiple: true, accept: '.ply,.obj,.off,.stl,.mfm,.png,.jpg,.jpeg',
  title: 'A mesh, and the texture images it names (they are drawn here, not uploaded)',
});
/** The mesh among the chosen files; images beside it are its textures, kept in the browser. */
const MESH_NAME = /\.(ply|obj|off|stl|mfm)$/i;
const inputUrl = el('input', { type: 'url', testid: 'input-url', placeholder: 'http://…/scan.ply', size: 50 });
const progress = el('progress', { testid: 'upload-progress', max: 1, value: 0, hidden: true });
const runButton = el('button', { testid: 'run', className: 'primary', onclick: () => startRun() }, 'Run');
const cancelButton = el('button', { testid: 'cancel', hidden: true, onclick: () => cancelRun() }, 'Cancel run');
const runNote = el('span', { className: 'note', testid: 'run-note' });
const runRoot = el('div', { className: 'run' });
const viewer = new Viewer(el('div', {}));
let current = null;
/** Uploaded inputs' names by URL (this page's uploads and history), so errors say the file. */
const inputNames = new Map();

fill(panels.build,
  el('h2', {}, 'Workflow'), builderRoot,
  el('h2', {}, 'Input'),
  el('p', {}, el('label', {}, 'Upload a mesh ', meshFile), ' ', progress, ' or ', el('label', {}, 'a URL ', inputUrl),
    el('br'), el('span', { className: 'note' }, 'With neither, the workflow\'s own "input" is used.')),
  el('p', {}, runButton, ' ', cancelButton, ' ', runNote),
  el('div', { className: 'run-and-view' }, runRoot, viewer.root));

function open(id) {
  current?.close();
  viewer.clear();
  current = new RunView(runRoot, id, {
    show: (label, path) => viewer.load(label, path),
    input: (path) => viewer.setInput(path),
    nameOf: (url) => inputNames.get(url) ?? null,
  });
  cancelButton.hidden = false;
  showTab('build');
  current.follow();
}

async function cancelRun() {
  if (!current) return;
  try {
    await postJson(`/runs/${encodeURIComponent(current.id)}/cancel`, {});
  } catch (error) {
    runNote.textContent = error.message;
  }
}

/** Uploads the input if one is chosen, submits, and follows the new run. The button stays
 *  disabled until the engine has answered, so one click makes one run. */
async function startRun() {
  runButton.disabled = true;
  runNote.textContent = '';
  // The last run's view goes at once: nothing of it can be taken for the new run's.
  current?.close();
  current = null;
  viewer.clear();
  cancelButton.hidden = true;
  fill(runRoot, el('p', { testid: 'run-status', className: 'status', 'data-status': 'starting' }, 'Starting a new run…'));
  try {
    let input = inputUrl.value.trim() || null;
    const files = [...meshFile.files];
    const file = files.find((f) => MESH_NAME.test(f.name));
    viewer.useTextures(files.filter((f) => !MESH_NAME.test(f.name)), Boolean(file));
    if (!file && files.length) throw new Error('choose a mesh (.ply, .obj, .off, .stl or .mfm) with the images');
    if (file) {
      progress.hidden = false;
      progress.value = 0;
      runNote.textContent = `uploading ${file.name}…`;
      input = (await uploadInput(file, (share) => { progress.value = share; })).url;
      inputNames.set(input, file.name);
    }
    runNote.textContent = 'submitting…';
    const run = await postJson('/runs', { workflow: builder.workflow, input });
    runNote.textContent = '';
    open(run.id);
  } catch (error) {
    runNote.textContent = error.code === 'invalid-workflow' ? `Not valid: ${error.message}` : error.message;
    // No run started: say so where the run would show.
    fill(runRoot, el('p', { testid: 'run-status', className: 'status', 'data-status': 'refused' }, 'No run started.'));
  } finally {
    runButton.disabled = false;
    progress.hidden = true;
  }
}

// Catalogue, history, plugins.
const history = new History(el('div', {}), {
  open,
  named: (url, name) => inputNames.set(url, name),
  rerun: (submission) => {
    builder.load(submission.workflow);
    inputUrl.value = submission.input ?? '';
    meshFile.value = '';
    showTab('build');
    runNote.textContent = 'Loaded the run\'s workflow and input: change either, then Run.';
  },
});
fill(panels.catalogue, el('h2', {}, 'Services'), catalogueRoot);
fill(panels.history, el('h2', {}, 'Runs'), history.root);
const plugins = new Plugins(el('div', {}), { uploaded: () => refresh() });
fill(panels.plugins, el('h2', {}, 'Upload a plugin'), plugins.root);

/** Reads hosts and services; an unreachable engine or a 401 shows in words. */
async function refresh() {
  try {
    const [list, hosts] = await Promise.all([getJson('/services'), getJson('/hosts')]);
    const before = Object.keys(services).sort().join();
    services = Object.fromEntries(list.map((s) => [s.name, s]));
    drawCatalogue(catalogueRoot, list);
    plugins.drawHosts(hosts);
    banner.hidden = true;
    if (before !== Object.keys(services).sort().join()) builder.redraw();
  } catch (error) {
    banner.hidden = false;
    banner.textContent = error.kind === 'unreachable' ? `The engine cannot be reached: ${error.message}` : error.message;
  }
}

document.getElementById('app').replaceWith(el('div', { id: 'app' },
  el('header', {}, el('h1', {}, 'meshflow workbench'), tabBar, signedIn), banner, login,
  ...Object.values(panels)));
showTab('build');
showUser();
await refresh();
setInterval(refresh, POLL_MS);
const asked = new URLSearchParams(location.search).get('run');
if (asked) open(asked);

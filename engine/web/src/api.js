// The engine's HTTP API as the page uses it: every request carries the session's API token
// as a bearer header, and every failure becomes an ApiError saying in words what happened.

const TOKEN_KEY = 'meshflow-token';

export class ApiError extends Error {
  /** kind: 'unreachable' | 'unauthorized' | 'http'; code and status from the engine. */
  constructor(kind, message, { status = 0, code = '' } = {}) {
    super(message);
    this.kind = kind;
    this.status = status;
    this.code = code;
  }
}

/** Listeners told when the engine answers 401, so the page can ask for the token. */
const unauthorizedListeners = new Set();
export function onUnauthorized(listener) {
  unauthorizedListeners.add(listener);
}

export const token = {
  get: () => sessionStorage.getItem(TOKEN_KEY),
  set: (value) => (value ? sessionStorage.setItem(TOKEN_KEY, value) : sessionStorage.removeItem(TOKEN_KEY)),
};

/** Takes a `#token=…` fragment into the session and removes it from the address bar. */
export function takeTokenFromFragment() {
  const match = /(?:^#|&)token=([^&]*)/.exec(location.hash);
  if (!match) return;
  token.set(decodeURIComponent(match[1]));
  history.replaceState(null, '', location.pathname + location.search);
}

export function authHeaders(extra = {}) {
  const value = token.get();
  return value ? { ...extra, Authorization: `Bearer ${value}` } : extra;
}

/** The error an answer that is not 2xx stands for. */
export async function errorOf(response) {
  let code = `http-${response.status}`;
  let message = `the engine answered ${response.status} ${response.statusText}`;
  try {
    const body = await response.json();
    if (body?.error) ({ code, message } = body.error);
  } catch {
    // Not JSON: keep the status line.
  }
  if (response.status === 401) {
    unauthorizedListeners.forEach((listener) => listener());
    return new ApiError('unauthorized', `not signed in: ${message}`, { status: 401, code });
  }
  return new ApiError('http', message, { status: response.status, code });
}

/** fetch() with the token; throws ApiError when the engine cannot be reached or refuses. */
export async function request(path, options = {}) {
  let response;
  try {
    response = await fetch(path, { ...options, headers: authHeaders(options.headers) });
  } catch (error) {
    if (error.name === 'AbortError') throw error;
    throw new ApiError('unreachable', `the engine cannot be reached (${error.message}): is it running?`);
  }
  if (!response.ok) throw await errorOf(response);
  return response;
}

export async function getJson(path) {
  return (await request(path)).json();
}

export async function postJson(path, body) {
  const response = await request(path, {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify(body),
  });
  return response.json();
}

/** Uploads a mesh with XMLHttpRequest, whose upload progress fetch() does not report. */
export function uploadInput(file, onProgress) {
  return new Promise((resolve, reject) => {
    const xhr = new XMLHttpRequest();
    xhr.open('POST', `/inputs?name=${encodeURIComponent(file.name)}`);
    for (const [name, value] of Object.entries(authHeaders())) xhr.setRequestHeader(name, value);
    xhr.upload.onprogress = (event) => event.lengthComputable && onProgress(event.loaded / event.total);
    xhr.onerror = () => reject(new ApiError('unreachable', 'the engine cannot be reached: the upload failed'));
    xhr.onload = () => {
      let body = null;
      try {
        body = JSON.parse(xhr.responseText);
      } catch {
        // Handled below by the status.
      }
      if (xhr.status === 201 && body) return resolve(body);
      const message = body?.error?.message ?? `the engine answered ${xhr.status}`;
      if (xhr.status === 401) {
        unauthorizedListeners.forEach((listener) => listener());
        return reject(new ApiError('unauthorized', `not signed in: ${message}`, { status: 401 }));
      }
      reject(new ApiError('http', `the upload was refused: ${message}`, { status: xhr.status }));
    };
    xhr.send(file);
  });
}

/**
 * Follows `/runs/{id}/events` with fetch() (EventSource cannot send the token): calls
 * `onEvent(kind, data)` for each event until the stream ends or `signal` aborts.
 */
export async function followEvents(id, onEvent, signal) {
  const response = await request(`/runs/${encodeURIComponent(id)}/events`, {
    signal,
    headers: { Accept: 'text/event-stream' },
  });
  const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
  let buffer = '';
  for (;;) {
    const { value, done } = await reader.read();
    if (done) return;
    buffer += value.replace(/\r\n/g, '\n');
    let end;
    while ((end = buffer.indexOf('\n\n')) >= 0) {
      const block = buffer.slice(0, end);
      buffer = buffer.slice(end + 2);
      let kind = 'message';
      const data = [];
      for (const line of block.split('\n')) {
        if (line.startsWith('event:')) kind = line.slice(6).trim();
        else if (line.startsWith('data:')) data.push(line.slice(5).replace(/^ /, ''));
      }
      if (data.length) onEvent(kind, JSON.parse(data.join('\n')));
    }
  }
}

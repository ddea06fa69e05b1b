// Talking to the terrain server: JSON fetches whose failures become messages a person can act on.

export class ApiError extends Error {
  constructor(message, { status = 0, pointer = '' } = {}) {
    super(message);
    this.status = status;
    this.pointer = pointer;
  }
}

/// Fetches JSON from the server. A network failure says the server is unreachable; an HTTP error
/// carries the problem+json title, detail and field.
export async function fetchJson(url, { signal } = {}) {
  let response;
  try {
    response = await fetch(url, { signal, headers: { Accept: 'application/json' } });
  } catch (e) {
    if (e.name === 'AbortError') throw e;
    throw new ApiError(`The terrain server is unreachable (${url}): ${e.message}`);
  }
  const text = await response.text();
  let body = null;
  try {
    body = text ? JSON.parse(text) : null;
  } catch {
    body = null;
  }
  if (!response.ok) {
    const what = body && (body.detail || body.title);
    const where = body && body.pointer ? ` (at ${body.pointer})` : '';
    throw new ApiError(`${response.status} ${what || response.statusText}${where}`, {
      status: response.status,
      pointer: body?.pointer || '',
    });
  }
  if (body === null) throw new ApiError(`The server sent no JSON for ${url}`);
  return body;
}

export async function fetchText(url, { signal } = {}) {
  let response;
  try {
    response = await fetch(url, { signal });
  } catch (e) {
    if (e.name === 'AbortError') throw e;
    throw new ApiError(`The terrain server is unreachable (${url}): ${e.message}`);
  }
  if (!response.ok) throw new ApiError(`${response.status} ${response.statusText} for ${url}`, { status: response.status });
  return response.text();
}

/// Base64 (standard alphabet) to bytes.
export function decodeBase64(text) {
  const binary = atob(text);
  const bytes = new Uint8Array(binary.length);
  for (let i = 0; i < binary.length; ++i) bytes[i] = binary.charCodeAt(i);
  return bytes;
}

// The console server's routes, as the page calls them. Messages are the API's, in protobuf's JSON
// mapping (proto field names; 64-bit integers such as timestamps as decimal strings).

/// A failed call, in the daemon's words: code "OUT_OF_RANGE", message "T = ... is older ...".
export class ApiError extends Error {
  constructor(code, message) {
    super(`${code}: ${message}`);
    this.code = code;
    this.daemonMessage = message;
  }
}

async function answer(response) {
  const body = await response.json().catch(() => null);
  if (!response.ok) {
    throw new ApiError(body?.code ?? `HTTP ${response.status}`, body?.message ?? response.statusText);
  }
  return body;
}

export async function getJson(url) {
  return answer(await fetch(url));
}

export async function postJson(url, body) {
  return answer(await fetch(url, {
    method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) }));
}

/// The preview JPEG of a SceneUpdate (base64 in JSON) as an ImageBitmap, or null without one.
export async function previewImage(update) {
  if (!update.preview_jpeg) return null;
  const bytes = Uint8Array.from(atob(update.preview_jpeg), (c) => c.charCodeAt(0));
  return createImageBitmap(new Blob([bytes], { type: 'image/jpeg' }));
}

/// The coloured segments of the frame at `timestampNs`, or null when the daemon has none for it.
export async function segmentsImage(timestampNs) {
  const response = await fetch(`/api/segments.png?at_ns=${timestampNs}`);
  if (!response.ok) return null;
  return createImageBitmap(await response.blob());
}

// Every URL the dashboard uses is relative to the page, so the app works behind a reverse proxy that
// serves it under a sub-path (https://example.org/robot/ -> api/status is /robot/api/status).

export function httpUrl(path, base = document.baseURI) {
  if (path.startsWith("/")) throw new Error(`URL "${path}" must be relative (no leading slash)`);
  return new URL(path, base).toString();
}

// The websocket URL for a relative path: same host and sub-path as the page, ws: or wss: to match.
export function wsUrl(path, params = {}, base = document.baseURI) {
  const url = new URL(httpUrl(path, base));
  url.protocol = url.protocol === "https:" ? "wss:" : "ws:";
  for (const [key, value] of Object.entries(params)) url.searchParams.set(key, value);
  return url.toString();
}

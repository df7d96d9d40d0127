// The job's Server-Sent Events (docs/api.md "Events"): state, progress, submap, revision, preview.
// EventSource cannot send headers, so the token goes in the query string. The stream of a
// finished job ends after its final state event: close it then, or EventSource reconnects.

import { apiUrl, withToken } from './api.js';

const TERMINAL = new Set(['completed', 'failed', 'canceled']);

// handlers: { state(data), progress(data), submap(data, receivedAt), revision(data, receivedAt),
//            preview(data, receivedAt), error() }
export function subscribeJobEvents(jobId, handlers) {
  const source = new EventSource(withToken(apiUrl(`jobs/${encodeURIComponent(jobId)}/events`)));
  const parse = (e) => {
    try {
      return JSON.parse(e.data);
    } catch {
      return null;
    }
  };
  source.addEventListener('state', (e) => {
    const data = parse(e);
    if (!data) return;
    if (TERMINAL.has(data.state)) source.close();
    if (handlers.state) handlers.state(data);
  });
  for (const name of ['progress', 'submap', 'revision', 'preview']) {
    source.addEventListener(name, (e) => {
      const data = parse(e);
      if (data && handlers[name]) handlers[name](data, performance.now());
    });
  }
  source.onerror = () => {
    if (handlers.error) handlers.error(source.readyState);
  };
  return { close: () => source.close(), isTerminal: (s) => TERMINAL.has(s) };
}

export const isTerminalState = (state) => TERMINAL.has(state);

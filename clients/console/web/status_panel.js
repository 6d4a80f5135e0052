// The status panel and the link badge: what the daemon says of itself each second, and how the
// console's link to it stands.

const STATE_NAMES = {
  STREAMING: 'streaming', ENDED: 'recording ended', FAILED: 'failed', STOPPED: 'stopping',
  RECONNECTING: 'sensor reconnecting', SOURCE_STATE_UNSPECIFIED: '?',
};

function formatBytes(perSecond) {
  if (perSecond >= 1e6) return (perSecond / 1e6).toFixed(2) + ' MB/s';
  if (perSecond >= 1e3) return (perSecond / 1e3).toFixed(1) + ' kB/s';
  return perSecond + ' B/s';
}

function rows(table, pairs) {
  table.replaceChildren(...pairs.map(([name, value]) => {
    const row = document.createElement('tr');
    for (const text of [name, value]) {
      const cell = document.createElement('td');
      cell.textContent = text;
      row.appendChild(cell);
    }
    return row;
  }));
}

export class StatusPanel {
  constructor() {
    this.badge = document.getElementById('link-state');
    this.sourceLine = document.getElementById('source-line');
    this.table = document.getElementById('status-table');
    this.stages = document.getElementById('stage-table');
    this.previous = null;  // last status, for the frame rate
    this.fps = 0;
  }

  setLink(state, detail = '') {
    this.badge.className = 'badge ' + state;
    this.badge.textContent = detail ? `${state}: ${detail}` : state;
    this.badge.title = detail;
  }

  /// A `status` event: {status: GetStatusResponse} or {error: {code, message}}, and the link's
  /// bytes per second.
  update(event) {
    const link = formatBytes(event.link_bytes_per_s);
    if (event.error) {
      this.setLink('unreachable', `${event.error.code}: ${event.error.message}`);
      rows(this.table, [['daemon', `${event.error.code}: ${event.error.message}`], ['link', link]]);
      this.previous = null;
      return;
    }
    const s = event.status;
    if (this.previous && s.uptime_s > this.previous.uptime_s) {
      this.fps = (Number(s.frames_received) - Number(this.previous.frames_received)) /
                 (s.uptime_s - this.previous.uptime_s);
    }
    this.previous = s;
    const sensor = s.source_live ? (s.source_connected ? ', sensor connected' : ', sensor lost') : '';
    this.sourceLine.textContent = `${s.source} · ${STATE_NAMES[s.source_state] ?? s.source_state}`;
    const spanS = (Number(BigInt(s.cache.newest_ns) - BigInt(s.cache.oldest_ns)) / 1e9).toFixed(1);
    rows(this.table, [
      ['source', s.source],
      ['state', (STATE_NAMES[s.source_state] ?? s.source_state) + sensor],
      ['fps', this.fps.toFixed(1)],
      ['frames', `${s.frames_received} received, ${s.frames_processed} processed, ` +
                 `${s.frames_skipped} skipped`],
      ['cache', `${s.cache.frames}/${s.cache.capacity} frames, ${spanS} s`],
      ['link', link],
      ['session', `${s.session_id} · up ${Math.round(s.uptime_s)} s`],
      ...(s.source_message ? [['source says', s.source_message]] : []),
    ]);
    const header = '<tr><th>stage</th><th>last ms</th><th>median</th><th>p95</th></tr>';
    this.stages.innerHTML = header;
    for (const stage of s.stages) {
      const row = this.stages.insertRow();
      for (const text of [stage.stage, stage.last_ms.toFixed(1), stage.median_ms.toFixed(1),
                          stage.p95_ms.toFixed(1)]) {
        row.insertCell().textContent = text;
      }
    }
  }
}

// Recording from the page: the daemon records its source under its recordings root; progress
// arrives as `record` events on every open page.

import { postJson } from './api.js';

export class RecordPanel {
  constructor() {
    this.dir = document.getElementById('record-dir');
    this.seconds = document.getElementById('record-seconds');
    this.start = document.getElementById('btn-record');
    this.stop = document.getElementById('btn-record-stop');
    this.state = document.getElementById('record-state');
    const stamp = new Date().toISOString().slice(0, 19).replace(/[-:]/g, '').replace('T', '-');
    this.dir.value = `console-${stamp}`;
    this.start.addEventListener('click', () => this.begin());
    this.stop.addEventListener('click', () => postJson('/api/record/stop', {}).catch(() => {}));
  }

  async begin() {
    this.setRunning(true);
    this.show('starting…', '');
    try {
      await postJson('/api/record', { dir: this.dir.value, seconds: Number(this.seconds.value) });
    } catch (error) {
      this.setRunning(false);
      this.show(error.message, 'error');
    }
  }

  /// A `record` event: {state: recording|done|failed, progress: RecordProgress, code, message}.
  update(event) {
    const p = event.progress;
    const where = p?.dir || this.dir.value;
    const counts = p ? `${p.frames_written} frames, ${p.seconds.toFixed(1)} s` +
                       (Number(p.frames_dropped) > 0 ? `, ${p.frames_dropped} dropped` : '') : '';
    if (event.state === 'recording') {
      this.setRunning(true);
      this.show(`recording ${where}\n${counts}`, '');
    } else if (event.state === 'done') {
      this.setRunning(false);
      this.show(`written: ${where}\n${counts}`, '');
    } else {
      this.setRunning(false);
      this.show(`${event.code}: ${event.message}` + (counts ? `\n${counts}` : ''), 'error');
    }
  }

  setRunning(running) {
    this.start.disabled = running;
    this.stop.disabled = !running;
  }

  show(text, kind) {
    this.state.textContent = text;
    this.state.className = 'result ' + kind;
  }
}

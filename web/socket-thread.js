// socket-thread.js: where a view's socket runs. A module worker (socket-worker.js) when the
// page may start one, so that the page's draws hold up neither the frames' arrival times
// nor the voice; else (a page whose content security policy forbids workers, or a worker
// that fails to load) a SocketPump on the page itself, which does the same, only on the
// main thread. The worker is started from a blob that imports socket-worker.js by its full
// URL: a page of another origin that embeds the head (facewire-head.js) cannot start a
// worker from the server's URL, but may import the server's modules (the server answers
// cross-origin reads).

import { SocketPump } from "./socket-pump.js";

export class SocketThread {
  /** `onEvent(event)`: what the pump posts (socket-pump.js). */
  constructor(onEvent) {
    this.onEvent = onEvent;
    this.worker = null;
    this.pump = null;
    this.ready = false;
    /** Requests (with their transfers) made before the worker said it was ready. */
    this.queue = [];
    this.start();
  }

  start() {
    let blob = null;
    try {
      const url = new URL("./socket-worker.js", import.meta.url).href;
      blob = URL.createObjectURL(new Blob([`import ${JSON.stringify(url)};`], { type: "text/javascript" }));
      const worker = new Worker(blob, { type: "module" });
      worker.onmessage = ({ data }) => {
        if (data.kind !== "ready") {
          this.onEvent(data);
          return;
        }
        URL.revokeObjectURL(blob);
        this.ready = true;
        for (const [request, transfer] of this.queue.splice(0)) {
          worker.postMessage(request, transfer);
        }
      };
      worker.onerror = (event) => {
        if (!this.ready) {
          event.preventDefault();
          URL.revokeObjectURL(blob);
          worker.terminate();
          this.inPage();
        }
      };
      this.worker = worker;
    } catch {
      if (blob) {
        URL.revokeObjectURL(blob);
      }
      this.inPage();
    }
  }

  /** The pump on the page itself, given the requests made so far. */
  inPage() {
    this.worker = null;
    this.pump = new SocketPump((event) => this.onEvent(event));
    for (const [request] of this.queue.splice(0)) {
      this.pump.handle(request);
    }
  }

  /** A request for the pump (socket-pump.js `handle`), with the ports it hands over. */
  request(request, transfer = []) {
    if (this.pump) {
      this.pump.handle(request);
    } else if (this.ready) {
      this.worker.postMessage(request, transfer);
    } else {
      this.queue.push([request, transfer]);
    }
  }

  /** Stops the worker (its socket with it). */
  terminate() {
    this.worker?.terminate();
    this.worker = null;
  }
}

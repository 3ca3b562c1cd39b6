// playout-worklet.js: the voice played on the audio thread. An AudioWorklet processor that
// keeps the jitter buffer (playout.js): sources (the sockets' pumps, socket-pump.js) post
// decoded chunks and timeline changes on MessagePorts handed to it through its own port,
// as the page posts the delay its frames need beyond the jitter's; it plays the buffer, and tells the page
// (sound.js) where each piece of the voice was placed on the context's clock, with the
// buffer's numbers.

import { JitterBuffer } from "./playout.js";

class Playout extends AudioWorkletProcessor {
  constructor() {
    super();
    this.buffer = new JitterBuffer(sampleRate);
    this.port.onmessage = ({ data }) => {
      if (data.source) {
        data.source.onmessage = ({ data: message }) => this.fromSource(message);
      } else if (data.faceExtraS !== undefined) {
        this.buffer.setFaceExtra(data.faceExtraS);
      }
    };
  }

  /** A source's message: `chunk`, `restart` (with `rate`) or `reset`. */
  fromSource(message) {
    if (message.type === "chunk") {
      const piece = this.buffer.push(message, currentFrame);
      this.port.postMessage({ piece, numbers: this.buffer.numbers() });
    } else if (message.type === "restart" || message.type === "reset") {
      if (message.type === "restart") {
        this.buffer.restart(message.rate);
      } else {
        this.buffer.reset();
      }
      this.port.postMessage({ restarted: this.buffer.rate });
    }
  }

  process(_inputs, outputs) {
    const channel = outputs[0]?.[0];
    if (channel) {
      this.buffer.render(channel, currentFrame);
    }
    return true;
  }
}

registerProcessor("facewire-playout", Playout);

// talk-worklet.js: the microphone's samples, off the audio thread. An AudioWorklet
// processor that hands each 128-sample block of its first input's first channel to the
// page (talk.js), which cuts them into 20 ms chunks for the producer socket.

class MicrophoneTap extends AudioWorkletProcessor {
  process(inputs) {
    const channel = inputs[0]?.[0];
    if (channel && channel.length > 0) {
      this.port.postMessage(channel.slice());
    }
    return true;
  }
}

registerProcessor("facewire-microphone", MicrophoneTap);

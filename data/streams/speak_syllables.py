#!/usr/bin/env python3
"""Speaks the 27 syllables with eSpeak NG and writes the syllable stream's voice.

Writes, beside this script:
  syllables.wav           16 kHz mono 16-bit PCM, 27 slots of 0.6 s (16.2 s)
  syllables.phonemes.tsv  per syllable, where its consonant and vowel sound in that file

facewire never runs this: `facewire syllables`, the demo and the tests read the two files
as committed, so the stream stays the same on every machine. Rerun it (after
`apt-get install espeak-ng`) to remake them; it only needs the standard library and
libespeak-ng.so.1, whose phoneme events give each phoneme's sample position.

Each syllable is synthesized on its own (Spanish voice, as the thesis recorded it) and
placed in its slot so that its consonant begins CONSONANT_AT_S into the slot, where the
stream's mouth reaches the consonant; core/src/stream/syllables.rs derives the rest of the
motion from the phoneme times. The 22,050 Hz output of eSpeak NG is resampled to 16 kHz
with a windowed-sinc low-pass at 7.2 kHz.
"""

import ctypes
import math
import os
import struct
import sys
import wave

SYLLABLES = [c + v for c in "ptkbmfsyd" for v in "aiu"]
SLOT_S = 0.6
CONSONANT_AT_S = 0.10
# Speaking rate, words per minute: slow and clear, as a syllable is said to be lip-read.
RATE_WPM = 130
VOICE = b"es"
OUT_RATE = 16000
# Half the resampling filter's length in input samples, and its cut-off.
TAPS_HALF = 24
CUTOFF_HZ = 7200.0

# espeak_EVENT from speak_lib.h (eSpeak NG 1.49 and later).
class Event(ctypes.Structure):
    _fields_ = [
        ("type", ctypes.c_int),
        ("unique_identifier", ctypes.c_uint),
        ("text_position", ctypes.c_int),
        ("length", ctypes.c_int),
        ("audio_position", ctypes.c_int),
        ("sample", ctypes.c_int),
        ("user_data", ctypes.c_void_p),
        ("id", ctypes.c_char * 8),
    ]


EVENT_LIST_TERMINATED = 0
EVENT_PHONEME = 7
AUDIO_OUTPUT_SYNCHRONOUS = 2
INITIALIZE_PHONEME_EVENTS = 1
PARAMETER_RATE = 1
Callback = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_short), ctypes.c_int, ctypes.POINTER(Event))


class Speaker:
    def __init__(self):
        self.lib = ctypes.CDLL("libespeak-ng.so.1")
        self.rate = self.lib.espeak_Initialize(AUDIO_OUTPUT_SYNCHRONOUS, 200, None, INITIALIZE_PHONEME_EVENTS)
        if self.rate <= 0:
            sys.exit("espeak_Initialize failed")
        if self.lib.espeak_SetVoiceByName(VOICE) != 0:
            sys.exit(f"eSpeak NG has no voice {VOICE.decode()}")
        self.lib.espeak_SetParameter(PARAMETER_RATE, RATE_WPM, 0)
        self.samples = []
        self.phonemes = []
        self.callback = Callback(self._on_synth)
        self.lib.espeak_SetSynthCallback(self.callback)

    def _on_synth(self, wav, count, events):
        if wav and count > 0:
            self.samples.extend(wav[:count])
        i = 0
        while events[i].type != EVENT_LIST_TERMINATED:
            event = events[i]
            if event.type == EVENT_PHONEME:
                self.phonemes.append((event.id.decode(), event.sample))
            i += 1
        return 0

    def speak(self, text):
        """The samples (at self.rate) and [(phoneme, sample)] of `text`."""
        self.samples, self.phonemes = [], []
        data = text.encode()
        self.lib.espeak_Synth(data, len(data) + 1, 0, 0, 0, 0, None, None)
        self.lib.espeak_Synchronize()
        return self.samples, self.phonemes


def resample(samples, rate_in, rate_out):
    """Windowed-sinc (Blackman) resampling of int samples; floats out."""
    step = rate_in / rate_out
    cutoff = CUTOFF_HZ / rate_in
    out = []
    for n in range(int(len(samples) / step)):
        centre = n * step
        first = max(0, math.floor(centre) - TAPS_HALF + 1)
        last = min(len(samples) - 1, math.floor(centre) + TAPS_HALF)
        acc = 0.0
        for k in range(first, last + 1):
            x = k - centre
            sinc = 2 * cutoff if x == 0 else math.sin(2 * math.pi * cutoff * x) / (math.pi * x)
            w = x / (2 * TAPS_HALF) + 0.5
            window = 0.42 - 0.5 * math.cos(2 * math.pi * w) + 0.08 * math.cos(4 * math.pi * w)
            acc += samples[k] * sinc * window
        out.append(acc)
    return out


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    speaker = Speaker()
    slot = round(SLOT_S * OUT_RATE)
    voice = [0.0] * (slot * len(SYLLABLES))
    rows = []
    for index, syllable in enumerate(SYLLABLES):
        samples, phonemes = speaker.speak(syllable)
        sounds = [(name, at) for name, at in phonemes if not name.startswith("_")]
        pauses = [at for name, at in phonemes if name.startswith("_")]
        if len(sounds) != 2:
            sys.exit(f"{syllable}: eSpeak NG gave phonemes {phonemes}, expected a consonant and a vowel")
        (_, consonant), (_, vowel) = sounds
        vowel_end = min((at for at in pauses if at > vowel), default=len(samples))
        to_out = OUT_RATE / speaker.rate
        shift = index * slot + round(CONSONANT_AT_S * OUT_RATE) - round(consonant * to_out)
        spoken = resample(samples, speaker.rate, OUT_RATE)
        if shift < index * slot or shift + len(spoken) > (index + 1) * slot:
            sys.exit(f"{syllable}: {len(samples) / speaker.rate:.3f} s of speech does not fit its {SLOT_S} s slot")
        for i, value in enumerate(spoken):
            voice[shift + i] += value
        rows.append(
            (
                syllable,
                shift + round(consonant * to_out),
                shift + round(vowel * to_out),
                shift + round(vowel_end * to_out),
                "+".join(name for name, _ in sounds),
            )
        )
    peak = max(abs(v) for v in voice)
    gain = min(1.0, 0.9 * 32767 / peak) if peak else 1.0
    pcm = struct.pack(f"<{len(voice)}h", *(max(-32768, min(32767, round(v * gain))) for v in voice))
    with wave.open(os.path.join(here, "syllables.wav"), "wb") as out:
        out.setnchannels(1)
        out.setsampwidth(2)
        out.setframerate(OUT_RATE)
        out.writeframes(pcm)
    with open(os.path.join(here, "syllables.phonemes.tsv"), "w") as out:
        out.write(f"# The syllable stream's voice (syllables.wav, {OUT_RATE} Hz): where each syllable's\n")
        out.write("# consonant starts, its vowel starts and its vowel ends, in samples from the file's start,\n")
        out.write(f"# from eSpeak NG's phoneme events (voice {VOICE.decode()}, {RATE_WPM} wpm). Made by speak_syllables.py.\n")
        out.write("# syllable\tconsonant\tvowel\tvowel_end\tphonemes\n")
        for row in rows:
            out.write("\t".join(str(x) for x in row) + "\n")
    print(f"wrote {len(voice) / OUT_RATE:.1f} s of voice and {len(rows)} syllables' phoneme times")


if __name__ == "__main__":
    main()

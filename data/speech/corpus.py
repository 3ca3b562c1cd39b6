"""Speech with exact phoneme timing, its visemes, and seeded augmentation, for the speech corpus.

Three synthesizers each return (samples, segments): float samples at RATE (16 kHz) and
contiguous segments (start_s, end_s, phoneme) from 0 to the end of the audio, in the
synthesizer's own phoneme symbols, silence included:

  Espeak       eSpeak NG through libespeak-ng.so.1; phoneme events give each phoneme's
               start sample in the 22,050 Hz output.
  festival()   Festival in one `festival -b` process per batch; utt.save.segs gives
               each segment's end time.
  flite()      Flite, whose -psdur prints each segment's end time.

viseme_of() maps every symbol of their phone sets (VISEME_TABLES; Festival's voices have
several, FESTIVAL_VOICES) to one of VISEMES; augment() applies a drawn Augmentation,
keeping the segments aligned with the audio.
"""

import ctypes
import math
import os
import pickle
import subprocess
import tempfile
import wave
from dataclasses import dataclass

import numpy as np
from scipy import signal

RATE = 16000
VISEMES = ("sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "ih", "oh", "ou")
# Segments that take the viseme of the sound after them (h, glottal stop).
FOLLOWING = "following"
# Peak level of clean speech before augmentation (-6 dBFS).
PEAK = 0.5


class UnknownPhoneme(ValueError):
    """A synthesizer produced a phoneme symbol that has no viseme."""


def _table(groups):
    """{symbol: viseme} from {viseme: symbols separated by spaces}."""
    table = {}
    for viseme, symbols in groups.items():
        assert viseme in VISEMES or viseme == FOLLOWING, viseme
        for symbol in symbols.split():
            assert symbol not in table, symbol
            table[symbol] = viseme
    return table


# eSpeak NG's English phoneme mnemonics (the symbols its English voices produce, found by
# speaking every word of texts.py and more with each of them), stress marks removed.
# ";" is the palatal glide eSpeak NG puts between i and a vowel ("Fiona");
# IR and VR are the Scottish voice's r-coloured vowels ("bird", "word"); w# is its "wh".
ESPEAK_VISEMES = _table(
    {
        "sil": "_ _: _! _|",
        "PP": "p b m",
        "FF": "f v",
        "TH": "T D",
        "DD": "t d t# t2 t[",
        "kk": "k g N x",
        "CH": "tS dZ S Z",
        "SS": "s z",
        "nn": "n l n- @L",
        "RR": "r r- 3 3: IR VR",
        "aa": "a a# aa A: A@ aI aI2 aI3 aI@ aU aU3 @ @2 @5 V",
        "E": "E e@ eI",
        "ih": "i i: I I# I2 i@ i@3 j ;",
        "oh": "0 O2 O: O@ o@ oU OI",
        "ou": "u: U U@ w w#",
        FOLLOWING: "h ?",
    }
)
# Festival's radio phone set and Flite's cmu phone set (the same ARPAbet names).
ARPABET_VISEMES = _table(
    {
        "sil": "pau h# brth sil",
        "PP": "p b m em",
        "FF": "f v",
        "TH": "th dh",
        "DD": "t d dx",
        "kk": "k g ng",
        "CH": "ch jh sh zh",
        "SS": "s z",
        "nn": "n l el en nx",
        "RR": "r er axr",
        "aa": "aa ae ah ax aw ay",
        "E": "eh ey",
        "ih": "ih iy y",
        "oh": "ao ow oy",
        "ou": "uh uw w",
        FOLLOWING: "hh hv",
    }
)
# The phone sets of Festival's other voices (training only), each every symbol of the phone
# set the voice selects (PhoneSet.description), from its defPhoneSet features and the
# voice's letter-to-sound rules. Velar nasals go to kk, as ng and N do above.
# Italian (voice_lp_diphone, voice_pc_diphone): 1 marks stress; nf is the labiodental
# nasal of "anfora", J and L are gn and gli.
ITALIAN_VISEMES = _table(
    {
        "sil": "#",
        "PP": "p b m",
        "FF": "f v nf",
        "DD": "t d",
        "kk": "k g ng",
        "CH": "S Z tS dZ",
        "SS": "s z ts dz",
        "nn": "n J l L",
        "RR": "r",
        "aa": "a a1",
        "E": "e e1 E E1",
        "ih": "i i1 j",
        "oh": "o o1 O O1",
        "ou": "u u1 w",
    }
)
# Czech (czech.scm; voice_czech_dita, _krb, _machac, _ph): ~ marks the hacek (c~ is c with
# a hacek, t~ and d~ are the palatal stops), : a long vowel; c is ts, ch the velar
# fricative x, n* the n before k and g, r~* the voiceless r with a hacek, _ the stroke
# between two vowels, # a pause; h is the glottal fricative.
CZECH_VISEMES = _table(
    {
        "sil": "# _",
        "PP": "p b m",
        "FF": "f v",
        "DD": "t d t~ d~",
        "kk": "k g ch n*",
        "CH": "c~ dz~ s~ z~",
        "SS": "s z c dz",
        "nn": "n n~ l",
        "RR": "r r~ r~*",
        "aa": "a a:",
        "E": "e e:",
        "ih": "i i: j",
        "oh": "o o:",
        "ou": "u u:",
        FOLLOWING: "h",
    }
)
# Russian (msu_ru_nsh_phoneset.scm; voice_msu_ru_nsh_clunits): a doubled consonant is the
# soft one, a doubled vowel the stressed one; ae, ay and ur are the most reduced vowels,
# c is ts, ch and sch the soft affricate and fricative, h the velar fricative x, y and yy
# the vowel of "ty".
RUSSIAN_VISEMES = _table(
    {
        "sil": "pau",
        "PP": "p pp b bb m mm",
        "FF": "f ff v vv",
        "DD": "t tt d dd",
        "kk": "k kk g gg h hh",
        "CH": "ch sh sch zh",
        "SS": "s ss z zz c",
        "nn": "n nn l ll",
        "RR": "r rr",
        "aa": "aa a ae ay",
        "E": "ee e",
        "ih": "ii i yy y j",
        "oh": "oo",
        "ou": "uu u ur",
    }
)
# Finnish (finnish_phones.scm, simplified WorldBet; voice_suo_fi_lj_diphone,
# voice_hy_fi_mv_diphone): : marks a long sound; @ is a (open front), 7 is o (front
# rounded), y the front rounded close vowel, & a schwa, T and D: the English th, N the
# velar nasal, ## a phrase break.
FINNISH_VISEMES = _table(
    {
        "sil": "## #",
        "PP": "p b m p: b: m:",
        "FF": "f v f: v:",
        "TH": "T T: D:",
        "DD": "t d t: d:",
        "kk": "k g N k: g: N:",
        "CH": "S S: Z:",
        "SS": "s s: z:",
        "nn": "n l L n: l: L:",
        "RR": "r r:",
        "aa": "a a: @ @: &",
        "E": "e e:",
        "ih": "i i: y y: j j:",
        "oh": "o o: 7 7:",
        "ou": "u u: w w:",
        FOLLOWING: "h h:",
    }
)
# Central Catalan (upc_catalan_phones-central.scm; voice_upc_ca_ona_hts): 1 marks stress,
# ax is the schwa, J and L are ny and ll, rr the trill, _ and # pauses.
CATALAN_VISEMES = _table(
    {
        "sil": "pau _ #",
        "PP": "p b m",
        "FF": "f",
        "DD": "t d",
        "kk": "k g",
        "CH": "S Z",
        "SS": "s z",
        "nn": "n J l L",
        "RR": "r rr",
        "aa": "a a1 ax",
        "E": "e e1 E E1",
        "ih": "i i1 j",
        "oh": "o o1 O O1",
        "ou": "u u1 w",
    }
)
# The phone set of the three IIT Madras / C-DAC voices (hindi_phones.scm, and the same
# in marathi_ and telugu_phones.scm; voice_hindi_NSK_diphone, voice_marathi_NSK_diphone,
# voice_telugu_NSK_diphone): T D N td are the retroflex stops and nasal, th dh tth ddh
# the dental stops (so DD, not TH), bh kh gh the aspirates (the letter-to-sound rules
# write most aspirates as the stop then h), j the affricate of "jal", y the glide, L the
# retroflex lateral, R the flap, v the labiodental approximant, ksh and sri the clusters
# of ksha and shri, @ a long central vowel. The set's featureless x, which the rules
# never write, has no viseme.
INDIC_VISEMES = _table(
    {
        "sil": "pau",
        "PP": "p b bh m",
        "FF": "f v",
        "DD": "T D td th dh tth ddh",
        "kk": "k g kh gh",
        "CH": "ch j sh zh ksh sri",
        "SS": "s",
        "nn": "n N l L",
        "RR": "r R",
        "aa": "a aa @",
        "E": "eh ee ay",
        "ih": "ih iy y",
        "oh": "oh oo aw",
        "ou": "uh uw w",
        FOLLOWING: "h",
    }
)
# Phone set: its visemes. "festival" is Festival's radio phone set (its English voices),
# "flite" Flite's cmu phone set.
VISEME_TABLES = {
    "espeak": ESPEAK_VISEMES,
    "festival": ARPABET_VISEMES,
    "flite": ARPABET_VISEMES,
    "italian": ITALIAN_VISEMES,
    "czech": CZECH_VISEMES,
    "russian": RUSSIAN_VISEMES,
    "finnish": FINNISH_VISEMES,
    "catalan": CATALAN_VISEMES,
    "indic": INDIC_VISEMES,
}
PAUSE = {
    "espeak": "_", "festival": "pau", "flite": "pau",
    "italian": "#", "czech": "#", "russian": "pau", "finnish": "#", "catalan": "pau", "indic": "pau",
}


def viseme_of(phoneme, phoneset, following="sil"):
    """The viseme of `phoneme` of `phoneset` (a key of VISEME_TABLES: "espeak", "festival",
    "flite", or the phone set of another Festival voice, FESTIVAL_VOICES).

    h and glottal stops take `following`, the viseme of the sound after them.
    Raises UnknownPhoneme, naming the symbol and the phone set, for a symbol with no viseme.
    """
    symbol = phoneme.lstrip("',%=") if phoneset == "espeak" else phoneme
    viseme = VISEME_TABLES[phoneset].get(symbol)
    if viseme is None:
        raise UnknownPhoneme(f"{phoneset} phoneme {phoneme!r} has no viseme")
    return following if viseme == FOLLOWING else viseme


def is_pause(phoneme, phoneset):
    """Whether `phoneme` is silence (its viseme is sil whatever follows)."""
    return viseme_of(phoneme, phoneset, FOLLOWING) == "sil"


def visemes(segments, phoneset):
    """The viseme of each of `segments`, h and glottal stops taking the next one's (sil at the end)."""
    out = []
    following = "sil"
    for _, _, phoneme in reversed(segments):
        following = viseme_of(phoneme, phoneset, following)
        out.append(following)
    return out[::-1]


def contiguous(ends, duration, pause):
    """Segments (start_s, end_s, phoneme) from [(end_s, phoneme)], covering 0 to `duration`.

    A last segment that runs past the audio (Flite's final pause does) is cut at its end;
    audio after the last segment becomes a `pause` segment. Empty segments are dropped.
    """
    segments = []
    start = 0.0
    for end, phoneme in ends:
        end = min(end, duration)
        if end > start:
            segments.append((start, end, phoneme))
            start = end
    if start < duration:
        if segments and segments[-1][2] == pause:
            segments[-1] = (segments[-1][0], duration, pause)
        else:
            segments.append((start, duration, pause))
    return segments


def to_rate(samples, rate):
    """`samples` (float) resampled from `rate` to RATE with scipy's polyphase filter."""
    if rate == RATE:
        return samples
    g = math.gcd(RATE, rate)
    return signal.resample_poly(samples, RATE // g, rate // g)


def read_wav(path):
    """The float samples (full scale 1.0) and rate of a 16-bit mono wav."""
    with wave.open(path, "rb") as w:
        if w.getsampwidth() != 2 or w.getnchannels() != 1:
            raise ValueError(f"{path}: not 16-bit mono")
        return np.frombuffer(w.readframes(w.getnframes()), "<i2") / 32768.0, w.getframerate()


def write_wav(path, samples):
    """`samples` (full scale 1.0) to a 16 kHz mono 16-bit wav, clipped to the int16 range."""
    pcm = np.clip(np.round(np.asarray(samples) * 32767.0), -32768, 32767).astype("<i2")
    with wave.open(path, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(RATE)
        w.writeframes(pcm.tobytes())


def normalised(samples):
    """`samples` scaled to a peak of PEAK."""
    peak = np.max(np.abs(samples)) if len(samples) else 0.0
    return samples * (PEAK / peak) if peak > 0 else samples


class _EspeakEvent(ctypes.Structure):
    """espeak_EVENT of speak_lib.h (eSpeak NG 1.49 and later)."""

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


_SynthCallback = ctypes.CFUNCTYPE(
    ctypes.c_int, ctypes.POINTER(ctypes.c_short), ctypes.c_int, ctypes.POINTER(_EspeakEvent)
)


class Espeak:
    """eSpeak NG through libespeak-ng.so.1 and its phoneme events.

    eSpeak NG carries state from one utterance to the next (the same call twice gives
    different samples), so this process only initialises it: every utterance is spoken
    in a child forked from here, which starts from that state, and whose result comes
    back through a pipe. The output then depends only on the arguments.
    """

    EVENT_LIST_TERMINATED = 0
    EVENT_PHONEME = 7
    AUDIO_OUTPUT_SYNCHRONOUS = 2
    INITIALIZE_PHONEME_EVENTS = 1
    RATE, PITCH, RANGE = 1, 3, 4

    def __init__(self):
        self.lib = ctypes.CDLL("libespeak-ng.so.1")
        self.libc = ctypes.CDLL(None)
        self.rate = self.lib.espeak_Initialize(self.AUDIO_OUTPUT_SYNCHRONOUS, 200, None, self.INITIALIZE_PHONEME_EVENTS)
        if self.rate <= 0:
            raise RuntimeError("espeak_Initialize failed")
        self.lib.espeak_Info.restype = ctypes.c_char_p
        data_path = ctypes.c_char_p()
        self.lib.espeak_Info(ctypes.byref(data_path))
        self.data_path = data_path.value.decode()
        self.chunks = []
        self.events = []
        self.callback = _SynthCallback(self._on_synth)
        self.lib.espeak_SetSynthCallback(self.callback)

    def _on_synth(self, wav, count, events):
        """Keeps the audio and the phoneme events eSpeak NG hands over."""
        if wav and count > 0:
            self.chunks.append(np.ctypeslib.as_array(wav, (count,)).copy())
        i = 0
        while events[i].type != self.EVENT_LIST_TERMINATED:
            if events[i].type == self.EVENT_PHONEME:
                self.events.append((events[i].sample, events[i].id.decode()))
            i += 1
        return 0

    def _speak(self, text, voice, rate, pitch, pitch_range, seed):
        """The raw int16 samples (at self.rate) and [(start sample, phoneme)] of one utterance,
        spoken in a forked child."""
        read, write = os.pipe()
        pid = os.fork()
        if pid == 0:
            os.close(read)
            try:
                result = ("ok", self._speak_here(text, voice, rate, pitch, pitch_range, seed))
            except Exception as error:
                result = ("error", error)
            with os.fdopen(write, "wb") as out:
                pickle.dump(result, out)
            os._exit(0)
        os.close(write)
        with os.fdopen(read, "rb") as answer:
            status, result = pickle.load(answer)
        os.waitpid(pid, 0)
        if status == "error":
            raise result
        return result

    def _speak_here(self, text, voice, rate, pitch, pitch_range, seed):
        """_speak() in this process."""
        if self.lib.espeak_SetVoiceByName(voice.encode()) != 0:
            raise ValueError(f"eSpeak NG has no voice {voice}")
        for parameter, value in ((self.RATE, rate), (self.PITCH, pitch), (self.RANGE, pitch_range)):
            self.lib.espeak_SetParameter(parameter, int(value), 0)
        self.libc.srand(ctypes.c_uint(seed & 0xFFFFFFFF))
        self.chunks, self.events = [], []
        data = text.encode()
        self.lib.espeak_Synth(data, len(data) + 1, 0, 0, 0, 0, None, None)
        self.lib.espeak_Synchronize()
        raw = np.concatenate(self.chunks) if self.chunks else np.zeros(0, np.int16)
        return raw, self.events

    def echoes(self, voice):
        """Whether `voice`'s variant adds an echo (an "echo" line in its file), which fills
        the silences with sound."""
        if "+" not in voice:
            return False
        with open(os.path.join(self.data_path, "voices", "!v", voice.split("+", 1)[1])) as variant:
            return any(line.split()[:1] == ["echo"] and line.split()[1:2] != ["0"] for line in variant)

    @staticmethod
    def _silences(raw, events):
        """Per event, the run of zero samples just before it when it and the event before
        it are sounds (0 otherwise), kept inside the sound before it."""
        runs = [0]
        for (before, previous), (start, phoneme) in zip(events, events[1:]):
            run = 0
            if not is_pause(previous, "espeak") and not is_pause(phoneme, "espeak"):
                while start - run > before + 1 and raw[start - run - 1] == 0:
                    run += 1
            runs.append(run)
        return runs

    def synth(self, text, voice="en-us", rate=175, pitch=50, pitch_range=50, seed=0):
        """(samples at RATE, segments) of `text` spoken by `voice` (e.g. "en-gb-x-rp+m3").

        `rate` is in words per minute; `pitch` and `pitch_range` are 0-99. `seed` seeds the
        C library's rand(), which eSpeak NG uses for its noise sources.

        eSpeak NG emits a phoneme's event after the silence before it: the closure of p,
        t, k and ch (30-70 ms), the short gap before f or h. Each such run of silent
        samples between two sounds is given to the sound after it. A variant with an echo
        (m2, f2-f5) fills the silences, so their lengths are taken from the accent spoken
        without the variant, phoneme by phoneme (pauses do not depend on the variant).
        """
        raw, events = self._speak(text, voice, rate, pitch, pitch_range, seed)
        if self.echoes(voice):
            plain, plain_events = self._speak(text, voice.split("+")[0], rate, pitch, pitch_range, seed)
            if [p for _, p in plain_events] != [p for _, p in events]:
                raise RuntimeError(f"eSpeak NG gives {voice} other phonemes than its accent for {text!r}")
            runs = self._silences(plain, plain_events)
        else:
            runs = self._silences(raw, events)
        starts = [(0, PAUSE["espeak"])]
        for (start, phoneme), run in zip(events, runs):
            starts.append((max(start - run, min(starts[-1][0] + 1, start)), phoneme))
        samples = to_rate(raw / 32768.0, self.rate)
        ends = [(starts[i + 1][0] / self.rate, starts[i][1]) for i in range(len(starts) - 1)]
        ends.append((math.inf, starts[-1][1]))
        return samples, contiguous(ends, len(samples) / RATE, PAUSE["espeak"])


@dataclass(frozen=True)
class FestivalVoice:
    """A Festival voice: the Scheme function that selects it, its phone set (a key of
    VISEME_TABLES), and whether its durations can be stretched (a cluster unit voice
    keeps those of the units it picks)."""

    function: str
    phoneset: str
    stretches: bool = True


FESTIVAL_VOICES = {
    "kal": FestivalVoice("voice_kal_diphone", "festival"),
    "kdl": FestivalVoice("voice_ked_diphone", "festival"),
    "slt-hts": FestivalVoice("voice_cmu_us_slt_arctic_hts", "festival"),
    "it-lp": FestivalVoice("voice_lp_diphone", "italian"),
    "it-pc": FestivalVoice("voice_pc_diphone", "italian"),
    "cs-dita": FestivalVoice("voice_czech_dita", "czech"),
    "cs-krb": FestivalVoice("voice_czech_krb", "czech"),
    "cs-machac": FestivalVoice("voice_czech_machac", "czech"),
    "cs-ph": FestivalVoice("voice_czech_ph", "czech"),
    "ru-nsh": FestivalVoice("voice_msu_ru_nsh_clunits", "russian", stretches=False),
    "fi-lj": FestivalVoice("voice_suo_fi_lj_diphone", "finnish"),
    "fi-mv": FestivalVoice("voice_hy_fi_mv_diphone", "finnish"),
    "ca-ona-hts": FestivalVoice("voice_upc_ca_ona_hts", "catalan"),
    "hi-nsk": FestivalVoice("voice_hindi_NSK_diphone", "indic"),
    "mr-nsk": FestivalVoice("voice_marathi_NSK_diphone", "indic"),
    "te-nsk": FestivalVoice("voice_telugu_NSK_diphone", "indic"),
}


def _scheme_string(text):
    """`text` as a Scheme string literal."""
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


class FestivalFailed(RuntimeError):
    """Festival gave no speech for a text, or (when asked) stood silence in for a missing diphone."""


def _stretch_line(voice, stretch):
    """The Scheme line that makes Festival's `voice` stretch durations by `stretch`:
    HTS's speed (-r 1/stretch) for an HTS voice, Duration_Stretch for the others."""
    spec = FESTIVAL_VOICES[voice]
    if not spec.stretches and stretch != 1.0:
        raise ValueError(f"festival voice {voice} keeps its own durations (stretch {stretch})")
    if spec.function.endswith("_hts"):
        params = spec.function.removeprefix("voice_") + "::hts_engine_params"
        return f"(set! hts_engine_params (append {params} '((\"-r\" {1.0 / stretch:.6f}))))"
    return f"(Parameter.set 'Duration_Stretch {stretch:.6f})"


def festival(requests, complete=False):
    """[(samples at RATE, segments)] for [(text, voice, stretch)], all in one festival process.

    `voice` is a key of FESTIVAL_VOICES; `stretch` scales durations (1.0 is the voice's
    own rate; see _stretch_line), and must be 1.0 for a voice that does not stretch.
    Raises FestivalFailed if a text gives no speech (Festival stops at a Scheme error) or,
    with `complete`, if UniSyn used its default diphone, a pause, for a missing one (the
    voices reading another language's text meet such pairs): the labels would put
    phonemes in that silence.
    """
    with tempfile.TemporaryDirectory(prefix="festival-") as tmp:
        lines = []
        current = None
        for i, (text, voice, stretch) in enumerate(requests):
            if voice != current:
                lines.append(f"({FESTIVAL_VOICES[voice].function})")
                current = voice
            lines.append(_stretch_line(voice, stretch))
            base = _scheme_string(os.path.join(tmp, str(i)))[:-1]
            lines.append(f"(set! utt (utt.synth (Utterance Text {_scheme_string(text)})))")
            lines.append(f"(utt.save.wave utt {base}.wav\" 'riff)")
            lines.append(f"(utt.save.segs utt {base}.segs\")")
        script = os.path.join(tmp, "batch.scm")
        with open(script, "w", encoding="utf-8") as out:
            out.write("\n".join(lines) + "\n")
        run = subprocess.run(["festival", "-b", script], capture_output=True, text=True, errors="replace")
        if complete and "using default diphone" in run.stderr:
            raise FestivalFailed(f"festival is missing a diphone for {[text for text, _, _ in requests]!r}")
        results = []
        for i, (text, voice, _) in enumerate(requests):
            path = os.path.join(tmp, str(i))
            if not (os.path.exists(path + ".wav") and os.path.exists(path + ".segs")):
                raise FestivalFailed(f"festival did not synthesize {text!r}: {run.stderr.strip()[-500:]}")
            raw, rate = read_wav(path + ".wav")
            with open(path + ".segs") as segs:
                ends = _festival_segs(segs.read())
            samples = to_rate(raw, rate)
            pause = PAUSE[FESTIVAL_VOICES[voice].phoneset]
            results.append((samples, contiguous(ends, len(samples) / RATE, pause)))
        return results


def _festival_segs(text):
    """[(end_s, phoneme)] from an utt.save.segs file ("#", then "END 100 NAME" lines)."""
    ends = []
    body = text.split("#", 1)[1]
    for line in body.strip().splitlines():
        end, _, phoneme = line.split()
        ends.append((float(end), phoneme))
    return ends


FLITE_VOICES = ("kal16", "awb", "rms", "slt")


def flite(text, voice, stretch=1.0):
    """(samples at RATE, segments) of `text` spoken by Flite's `voice` (one of FLITE_VOICES).

    `stretch` scales durations (duration_stretch; 1.0 is the voice's own rate).
    """
    if voice not in FLITE_VOICES:
        raise ValueError(f"unknown flite voice {voice}")
    with tempfile.TemporaryDirectory(prefix="flite-") as tmp:
        path = os.path.join(tmp, "out.wav")
        command = ["flite", "-voice", voice, "-psdur", "--setf", f"duration_stretch={stretch:.6f}"]
        command += ["-t", text, "-o", path]
        run = subprocess.run(command, capture_output=True, text=True, check=True)
        raw, rate = read_wav(path)
    ends = []
    for token in run.stdout.split():
        phoneme, end = token.rsplit(":", 1)
        if ends and float(end) < ends[-1][0]:
            raise RuntimeError(f"flite printed times out of order for {text!r}: {run.stdout}")
        ends.append((float(end), phoneme))
    samples = to_rate(raw, rate)
    return samples, contiguous(ends, len(samples) / RATE, PAUSE["flite"])


@dataclass
class Augmentation:
    """The choices of one item's augmentation (None: not applied)."""

    gain_db: float = 0.0
    noise: str = "none"
    snr_db: float | None = None
    rt60_s: float | None = None
    drr_db: float | None = None
    telephone: bool = False
    lead_s: float = 0.0
    trail_s: float = 0.0


NOISES = ("none", "white", "pink", "babble")


def draw_augmentation(rng):
    """A random Augmentation: gain -30..0 dB; noise none, white, pink or babble at 0-40 dB SNR;
    reverb (RT60 0.1-0.7 s, direct-to-reverberant ratio 0-12 dB) half the time; a telephone
    band one time in five; 0.1-0.6 s of silence before and after."""
    noise = NOISES[rng.choice(len(NOISES), p=(0.25, 0.2, 0.3, 0.25))]
    reverb = rng.random() < 0.5
    return Augmentation(
        gain_db=float(rng.uniform(-30.0, 0.0)),
        noise=noise,
        snr_db=None if noise == "none" else float(rng.uniform(0.0, 40.0)),
        rt60_s=float(rng.uniform(0.1, 0.7)) if reverb else None,
        drr_db=float(rng.uniform(0.0, 12.0)) if reverb else None,
        telephone=bool(rng.random() < 0.2),
        lead_s=float(rng.uniform(0.1, 0.6)),
        trail_s=float(rng.uniform(0.1, 0.6)),
    )


def pink_noise(n, rng):
    """`n` samples of unit-variance 1/f noise (white noise shaped in the frequency domain)."""
    spectrum = np.fft.rfft(rng.standard_normal(n))
    f = np.arange(len(spectrum), dtype=float)
    f[0] = 1.0
    noise = np.fft.irfft(spectrum / np.sqrt(f), n)
    return noise / (np.std(noise) or 1.0)


def babble(n, rng, bank, talkers=4):
    """`n` samples of unit-variance babble: `talkers` utterances of `bank`, each looped from
    a random offset, summed."""
    if not bank:
        raise ValueError("babble needs a bank of utterances")
    mix = np.zeros(n)
    for k in rng.choice(len(bank), size=min(talkers, len(bank)), replace=False):
        speech = bank[k] / (np.std(bank[k]) or 1.0)
        mix += np.resize(np.roll(speech, -int(rng.integers(len(speech)))), n)
    return mix / (np.std(mix) or 1.0)


def impulse_response(rt60_s, drr_db, rng):
    """A synthetic room response: 1 at sample 0 (the direct path, so nothing is delayed),
    then Gaussian noise decaying by 60 dB over `rt60_s`, whose energy is `drr_db` below
    the direct path's."""
    n = int(rt60_s * RATE)
    tail = rng.standard_normal(n) * 10.0 ** (-3.0 * np.arange(1, n + 1) / n)
    tail *= 10.0 ** (-drr_db / 20.0) / np.sqrt(np.sum(tail**2))
    return np.concatenate(([1.0], tail))


TELEPHONE_SOS = signal.butter(4, (300.0, 3400.0), btype="bandpass", fs=RATE, output="sos")


def augment(samples, segments, phoneset, augmentation, rng, bank=()):
    """(samples, segments) of speech in `phoneset` after `augmentation`; `bank` holds the
    utterances babble is made of.

    Order: silence added before and after (segments shifted), reverb, noise at the SNR
    (measured over the segments that are not silence), telephone band (zero-phase, so
    nothing moves), gain. Samples are floats at RATE with clean speech at a peak of PEAK.
    """
    a = augmentation
    lead, trail = round(a.lead_s * RATE), round(a.trail_s * RATE)
    x = np.concatenate((np.zeros(lead), samples, np.zeros(trail)))
    segments = padded(segments, lead / RATE, len(x) / RATE, PAUSE[phoneset])
    if a.rt60_s is not None:
        x = normalised(signal.fftconvolve(x, impulse_response(a.rt60_s, a.drr_db, rng))[: len(x)])
    if a.noise != "none":
        if a.noise == "white":
            noise = rng.standard_normal(len(x))
        elif a.noise == "pink":
            noise = pink_noise(len(x), rng)
        else:
            noise = babble(len(x), rng, bank)
        labels = visemes(segments, phoneset)
        speech = [x[round(s * RATE) : round(e * RATE)] for (s, e, _), v in zip(segments, labels) if v != "sil"]
        power = float(np.mean(np.concatenate(speech) ** 2)) if speech else float(np.mean(x**2))
        x = x + noise * np.sqrt(power / 10.0 ** (a.snr_db / 10.0))
    if a.telephone:
        x = signal.sosfiltfilt(TELEPHONE_SOS, x)
    return x * 10.0 ** (a.gain_db / 20.0), segments


def padded(segments, lead_s, duration, pause):
    """`segments` shifted by `lead_s`, with `pause` before them and after them up to
    `duration` (joined to a pause segment already there)."""
    shifted = [(s + lead_s, e + lead_s, p) for s, e, p in segments]
    if shifted and shifted[0][2] == pause:
        shifted[0] = (0.0, shifted[0][1], pause)
    elif lead_s > 0:
        shifted.insert(0, (0.0, lead_s, pause))
    end = shifted[-1][1] if shifted else 0.0
    if shifted and shifted[-1][2] == pause:
        shifted[-1] = (shifted[-1][0], duration, pause)
    elif duration > end:
        shifted.append((end, duration, pause))
    return shifted

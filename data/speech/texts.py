"""The texts of the speech corpus: held-out sentences and syllables, and random training text.

HELDOUT_SENTENCES and HELDOUT_SYLLABLES are spoken by the held-out voices only;
training_sentence(rng) builds random sentences from the word lists below (written for
this corpus, nothing downloaded) and never returns a held-out sentence. native_text(rng,
language) strings together words of NATIVE_WORDS, for the training voices whose text
processing reads only their own script (Festival's Russian, Hindi, Marathi and Telugu).
"""

import re

HELDOUT_SENTENCES = (
    "Bob bought a big bag of plums for Papa.",
    "The father moved the heavy box of blue boots.",
    "Both of them found the food very smooth.",
    "Mom put the warm soup on the bamboo mat.",
    "Five brave farmers pulled the van through the mud.",
    "The thin thief threw the book into the pool.",
    "Please move the blue broom from the bathroom floor.",
    "My brother plays the violin far from the park.",
    "Father found a few moths above the barn.",
    "The baby put both feet in the bath.",
    "Vivian wove a purple robe with woolen thread.",
    "Pam spilled warm milk on the fluffy pillow.",
    "The moon looked huge above the calm harbor.",
    "We booked a room with a view of the bay.",
    "Thank you for the fabulous food, mother.",
    "Put the spoon by the bowl of foam.",
    "The pilot flew the plane over the farm.",
    "Ruth found her favorite boots in the cupboard.",
    "A tall palm tree waved beneath the balmy sky.",
    "Bubbles floated up from the deep muddy pond.",
    "Matthew thought the puzzle was far too tough.",
    "Move five pebbles from the path to the box.",
    "My mother made fifty plump muffins this morning.",
    "The wolf stood by the bush and looked at the moon.",
    "Vera bought a pot of fresh mint and basil.",
    "The boys pushed the heavy boat through the foam.",
    "Father smiled and offered them both a bowl of broth.",
    "Every fool can play the tuba with a few tips.",
    "The bathroom mirror fogged up from the hot water.",
    "Barbara cooked beef with pepper and mushrooms.",
    "Three happy puppies played beside the old barn.",
    "Fill the cup with hot broth before noon.",
    "The sharp thorn poked my thumb and my palm.",
    "Prove the theory with better proof, please.",
    "A few brown moths flew past the lamp.",
    "Whoever took my book should put it back soon.",
    "Mabel found a smooth blue pebble on the beach.",
    "The marble statue of the father stood in the plaza.",
    "Both brothers bought a map of the vast valley.",
    "Beef, beans and bread were put on the plate.",
)

# The 27 syllables, consonant in "ptkbmfsyd" times vowel in "aiu", named by that pair.
# Spellings an English text-to-speech front end reads as one stressed syllable:
#   a -> "ah" (the vowel of "father"): pa tah kah bah mah fah sah yah dah ("pah" is
#        "p ae" in Festival's and Flite's lexicons, "pa" is "p aa")
#   i -> "ee" (the vowel of "see"), real words where the spelling would be odd:
#        pee tee key bee me fee see ye dee
#   u -> "oo" (the vowel of "food"), real words where the spelling would be odd:
#        poo too coo boo moo foo sue you do
SYLLABLE_SPELLINGS = {
    "a": dict(zip("ptkbmfsyd", ("pa", "tah", "kah", "bah", "mah", "fah", "sah", "yah", "dah"))),
    "i": dict(zip("ptkbmfsyd", ("pee", "tee", "key", "bee", "me", "fee", "see", "ye", "dee"))),
    "u": dict(zip("ptkbmfsyd", ("poo", "too", "coo", "boo", "moo", "foo", "sue", "you", "do"))),
}
HELDOUT_SYLLABLES = tuple(
    (consonant + vowel, SYLLABLE_SPELLINGS[vowel][consonant]) for consonant in "ptkbmfsyd" for vowel in "aiu"
)

NAMES = (
    "Bob", "Pam", "Mabel", "Vivian", "Ruth", "Matthew", "Barbara", "Fiona", "Victor", "Beth",
    "Paul", "Molly", "Theo", "Judy", "Hugo", "Martha", "Boris", "Phoebe", "Moira", "Jane",
    "George", "Sean", "Zoe", "Luke", "Rosa", "Walter", "Yusuf", "Chloe", "Nora", "Kevin",
)
DETERMINERS = ("the", "a", "my", "your", "our", "their", "this", "that", "every", "some", "one", "his", "her")
ADJECTIVES = (
    "big", "small", "brave", "blue", "brown", "purple", "pink", "black", "white", "green",
    "yellow", "orange", "red", "warm", "cool", "smooth", "rough", "soft", "thick", "thin",
    "deep", "shallow", "full", "empty", "happy", "bored", "busy", "foolish", "wise", "calm",
    "famous", "fresh", "free", "fine", "vast", "heavy", "huge", "tiny", "good", "bad",
    "young", "old", "new", "strong", "weak", "cheap", "sharp", "round", "loud", "quiet",
    "sweet", "sour", "bitter", "wooden", "woolen", "rubber", "golden", "silver", "muddy", "fluffy",
    "beautiful", "useful", "unusual", "pleasant", "funny", "lovely", "awful", "early", "late", "rare",
    "noisy", "shiny", "sleepy", "hungry", "thirsty", "curious", "gentle", "jolly", "major", "dark",
)
NOUNS = (
    "apple", "baby", "bag", "ball", "balloon", "bamboo", "banana", "barn", "bath", "bathroom",
    "bay", "beach", "bean", "bear", "bed", "bee", "beef", "bell", "bench", "bird",
    "boat", "book", "boot", "bottle", "bowl", "box", "boy", "bread", "bridge", "broom",
    "brother", "bubble", "bush", "butter", "cab", "cake", "calf", "car", "cart", "cat",
    "chair", "cheese", "child", "church", "coin", "cook", "cow", "cup", "cupboard", "dog",
    "door", "dream", "drum", "duck", "farm", "farmer", "father", "feather", "fence", "field",
    "fish", "flag", "flower", "flute", "foam", "food", "fool", "foot", "fork", "fox",
    "friend", "frog", "fruit", "garage", "garden", "girl", "glove", "goose", "guitar", "hammer",
    "hat", "heart", "hill", "hook", "horse", "house", "jam", "jar", "judge", "juice",
    "king", "kitten", "knife", "lamb", "lamp", "lawyer", "leaf", "lemon", "map", "mat",
    "measure", "melon", "milk", "mirror", "mob", "monkey", "moon", "moth", "mother", "mouse",
    "mouth", "mud", "muffin", "mule", "mushroom", "nephew", "noodle", "nurse", "orange", "owl",
    "palm", "pan", "paper", "park", "path", "pea", "peach", "pear", "pebble", "pen",
    "pepper", "piano", "pie", "pig", "pillow", "pilot", "pipe", "pizza", "plane", "plate",
    "plum", "pond", "pool", "pot", "puppy", "purse", "puzzle", "queen", "rabbit", "robe",
    "roof", "room", "rope", "ruby", "school", "sheep", "shoe", "soup", "spoon", "statue",
    "stove", "stream", "sugar", "table", "teeth", "thief", "thorn", "thread", "throne", "thumb",
    "tooth", "toy", "treasure", "tuba", "tube", "van", "vase", "vest", "village", "violin",
    "vision", "voice", "volcano", "wagon", "wall", "water", "weather", "whale", "window", "wolf",
    "wood", "wool", "word", "yard", "zebra", "zoo",
)
VERBS_PAST = (
    "bought", "brought", "pushed", "pulled", "moved", "found", "fed", "fixed", "filled", "followed",
    "loved", "saw", "saved", "threw", "thanked", "took", "put", "picked", "packed", "painted",
    "passed", "played", "poured", "proved", "booked", "borrowed", "boiled", "baked", "built", "bumped",
    "measured", "missed", "met", "mopped", "mended", "watched", "washed", "wanted", "viewed", "visited",
    "chose", "chased", "judged", "joined", "shared", "showed", "shook", "served", "sold", "sought",
    "touched", "tossed", "dropped", "dragged", "kicked", "kept", "caught", "cooked", "grabbed", "hugged",
    "heard", "held", "lifted", "liked", "reached", "ruined", "rubbed", "soothed", "bathed", "breathed",
)
VERBS = (
    "buy", "bring", "push", "pull", "move", "find", "feed", "fix", "fill", "follow",
    "love", "see", "save", "throw", "thank", "take", "put", "pick", "pack", "paint",
    "pass", "play", "pour", "prove", "book", "borrow", "boil", "bake", "build", "bump",
    "measure", "miss", "meet", "mop", "mend", "watch", "wash", "want", "view", "visit",
    "choose", "chase", "judge", "join", "share", "show", "shake", "serve", "sell", "seek",
    "touch", "toss", "drop", "drag", "kick", "keep", "catch", "cook", "grab", "hug",
)
VERBS_INTRANSITIVE = (
    "smiled", "laughed", "sighed", "frowned", "waved", "coughed", "sang", "danced", "jumped", "hummed",
    "mumbled", "slept", "swam", "paused", "nodded", "shivered", "yawned", "whispered", "bowed", "moaned",
)
PREPOSITIONS = (
    "by", "from", "above", "below", "beneath", "behind", "beside", "with", "without", "through",
    "over", "under", "near", "past", "into", "onto", "toward", "among", "before", "after",
)
ADVERBS = (
    "very", "fairly", "fully", "barely", "badly", "boldly", "bravely", "calmly", "promptly", "softly",
    "smoothly", "slowly", "quickly", "often", "always", "maybe", "perhaps", "truly", "thoroughly", "happily",
)
PRONOUNS = ("I", "you", "we", "they", "he", "she", "both of them", "nobody", "everybody", "somebody")
TIMES = (
    "this morning", "at noon", "on Thursday", "on Monday", "last month", "at dawn", "in the autumn",
    "before the party", "after the movie", "every evening", "at the weekend", "by the fifth of June",
)

ONSETS = ("p", "b", "m", "f", "v", "th", "t", "d", "k", "g", "ch", "j", "sh", "s", "z", "n", "l", "r", "w", "y", "h")
OPEN_VOWELS = ("ah", "ee", "oo", "oh", "ay", "aw", "oy")
CHECKED_VOWELS = ("a", "e", "i", "o", "u", "ee", "oo", "oa")
CODAS = ("p", "b", "m", "f", "v", "th", "t", "d", "k", "g", "n", "s", "z", "sh", "l", "ng")


def nonsense_syllable(rng):
    """A random CV ("thoo") or CVC ("boom") nonsense syllable."""
    onset = ONSETS[rng.integers(len(ONSETS))]
    if rng.random() < 0.5:
        return onset + OPEN_VOWELS[rng.integers(len(OPEN_VOWELS))]
    return onset + CHECKED_VOWELS[rng.integers(len(CHECKED_VOWELS))] + CODAS[rng.integers(len(CODAS))]


def _pick(rng, words):
    """One word of `words`."""
    return words[rng.integers(len(words))]


def _noun_phrase(rng):
    """A determiner, maybe an adjective or two, and a noun; sometimes a name."""
    if rng.random() < 0.15:
        return _pick(rng, NAMES)
    words = [_pick(rng, DETERMINERS)]
    for _ in range(rng.choice(3, p=(0.4, 0.45, 0.15))):
        words.append(_pick(rng, ADJECTIVES))
    words.append(_pick(rng, NOUNS))
    if words[0] == "a" and words[1][0] in "aeiou":
        words[0] = "an"
    return " ".join(words)


def _subject(rng):
    """A noun phrase or a pronoun."""
    return _pick(rng, PRONOUNS) if rng.random() < 0.3 else _noun_phrase(rng)


def _statement(rng):
    """A declarative clause in the past tense."""
    if rng.random() < 0.2:
        clause = f"{_subject(rng)} {_pick(rng, VERBS_INTRANSITIVE)}"
    else:
        clause = f"{_subject(rng)} {_pick(rng, VERBS_PAST)} {_noun_phrase(rng)}"
    if rng.random() < 0.5:
        clause += f" {_pick(rng, PREPOSITIONS)} {_noun_phrase(rng)}"
    if rng.random() < 0.25:
        clause += f" {_pick(rng, ADVERBS)}" if rng.random() < 0.5 else f" {_pick(rng, TIMES)}"
    return clause


def _question(rng):
    """A yes/no or wh- question."""
    opener = _pick(rng, ("did", "will", "can", "should", "why did", "where did", "who can", "how did"))
    if opener.startswith("who"):
        return f"{opener} {_pick(rng, VERBS)} {_noun_phrase(rng)}"
    return f"{opener} {_subject(rng)} {_pick(rng, VERBS)} {_noun_phrase(rng)}"


def _nonsense(rng):
    """A frame around a few nonsense syllables, or the syllables alone."""
    syllables = " ".join(nonsense_syllable(rng) for _ in range(rng.integers(1, 5)))
    frames = ("{n} said {s}", "say {s} again", "{s}", "the word is {s}", "{s}, said {n}", "{n} wrote {s} on the wall")
    return _pick(rng, frames).format(n=_pick(rng, NAMES), s=syllables)


def _normalised(text):
    """`text` in lower case with everything but letters and single spaces removed."""
    return " ".join(re.sub(r"[^a-z ]", " ", text.lower()).split())


_HELDOUT = {_normalised(sentence) for sentence in HELDOUT_SENTENCES} | {
    _normalised(spelling) for _, spelling in HELDOUT_SYLLABLES
}


def training_sentence(rng):
    """A random English sentence (sometimes with nonsense syllables); never a held-out text.

    `rng` is a numpy Generator; the same generator state gives the same sentence.
    """
    while True:
        kind = rng.random()
        if kind < 0.12:
            text = _nonsense(rng)
        elif kind < 0.3:
            text = _question(rng)
        else:
            text = _statement(rng)
            if rng.random() < 0.25:
                text += f", {_pick(rng, ('and', 'but', 'so', 'because', 'while'))} {_statement(rng)}"
        if _normalised(text) in _HELDOUT:
            continue
        end = "?" if 0.12 <= kind < 0.3 else _pick(rng, (".", ".", ".", "!"))
        return text[0].upper() + text[1:] + end


# Common words in the voices' own scripts, chosen to use every letter of the alphabet
# their letter-to-sound rules read (Cyrillic; Devanagari for Hindi and Marathi; Telugu).
NATIVE_WORDS = {
    "ru": (
        "мама", "папа", "книга", "вода", "рыба", "молоко", "хлеб", "дом", "окно", "стол",
        "солнце", "море", "город", "дерево", "птица", "собака", "кошка", "школа", "работа", "машина",
        "улица", "дорога", "друг", "брат", "сестра", "девочка", "мальчик", "утро", "вечер", "ночь",
        "зима", "лето", "весна", "осень", "большой", "маленький", "красивый", "новый", "старый", "хороший",
        "белый", "черный", "красный", "синий", "зеленый", "теплый", "холодный", "быстро", "медленно", "сегодня",
        "завтра", "вчера", "всегда", "читает", "пишет", "видит", "любит", "знает", "говорит", "идет",
        "живет", "смотрит", "думает", "играет", "поет", "спит", "и", "но", "в", "на",
        "под", "с", "мы", "вы", "они", "он", "она", "щука", "жук", "шапка",
        "часы", "цветы", "чай", "жизнь", "шум", "цирк", "яблоко", "юг", "мягкий", "пять",
        "семь", "съезд", "объем", "эхо", "фонарь", "гитара", "праздник", "площадь", "вещи", "тишина",
    ),
    "hi": (
        "नमस्ते", "पानी", "खाना", "घर", "किताब", "लड़का", "लड़की", "माता", "पिता", "भाई",
        "बहन", "दोस्त", "स्कूल", "शहर", "गाँव", "पेड़", "फूल", "आम", "दूध", "चाय",
        "रोटी", "सूरज", "चाँद", "बारिश", "हवा", "दिन", "रात", "सुबह", "शाम", "अच्छा",
        "बड़ा", "छोटा", "नया", "पुराना", "सुंदर", "लाल", "नीला", "हरा", "सफ़ेद", "काला",
        "जल्दी", "धीरे", "आज", "कल", "हमेशा", "खाता", "पीता", "देखता", "पढ़ता", "लिखता",
        "जाता", "आता", "सोता", "खेलता", "गाता", "है", "हैं", "और", "लेकिन", "में",
        "पर", "से", "को", "मैं", "तुम", "वह", "हम", "यह", "क्या", "क्यों",
        "कहाँ", "ठंडा", "झंडा", "ढोल", "थाली", "धन्यवाद", "फल", "भारत", "गंगा", "मछली",
        "छाता", "जंगल", "शेर", "हाथी", "घोड़ा", "बंदर", "कुत्ता", "बिल्ली", "ऋषि", "औरत",
        "ऊपर", "इधर", "उधर", "एक", "ऐनक", "ओस", "षट्कोण", "कृपया", "दुःख", "ईख",
    ),
    "mr": (
        "नमस्कार", "पाणी", "घर", "पुस्तक", "मुलगा", "मुलगी", "आई", "बाबा", "भाऊ", "बहीण",
        "मित्र", "शाळा", "शहर", "गाव", "झाड", "फूल", "आंबा", "दूध", "चहा", "भाकरी",
        "सूर्य", "चंद्र", "पाऊस", "वारा", "दिवस", "रात्र", "सकाळ", "संध्याकाळ", "चांगला", "मोठा",
        "लहान", "नवीन", "जुना", "सुंदर", "लाल", "निळा", "हिरवा", "पांढरा", "काळा", "लवकर",
        "हळू", "आज", "उद्या", "काल", "नेहमी", "खातो", "पितो", "बघतो", "वाचतो", "लिहितो",
        "जातो", "येतो", "झोपतो", "खेळतो", "गातो", "आहे", "आहेत", "आणि", "पण", "मध्ये",
        "वर", "मी", "तू", "तो", "ती", "आम्ही", "हे", "काय", "का", "कुठे",
        "धन्यवाद", "ठीक", "ढग", "थंड", "फळ", "घोडा", "छत्री", "झेंडा", "ऋतू", "औषध",
        "ऊस", "इथे", "एक", "ऐका", "ओळख", "षट्कोन", "कृपया", "दुःख", "ईश्वर", "अंगण",
    ),
    "te": (
        "నమస్కారం", "నీళ్ళు", "ఇల్లు", "పుస్తకం", "అబ్బాయి", "అమ్మాయి", "అమ్మ", "నాన్న", "అన్న", "అక్క",
        "స్నేహితుడు", "బడి", "నగరం", "ఊరు", "చెట్టు", "పువ్వు", "మామిడి", "పాలు", "కాఫీ", "అన్నం",
        "సూర్యుడు", "చంద్రుడు", "వాన", "గాలి", "రోజు", "రాత్రి", "ఉదయం", "సాయంత్రం", "మంచి", "పెద్ద",
        "చిన్న", "కొత్త", "పాత", "అందమైన", "ఎరుపు", "నీలం", "ఆకుపచ్చ", "తెలుపు", "నలుపు", "త్వరగా",
        "నెమ్మదిగా", "ఈరోజు", "రేపు", "నిన్న", "ఎప్పుడూ", "తింటాడు", "తాగుతాడు", "చూస్తాడు", "చదువుతాడు", "రాస్తాడు",
        "వెళ్తాడు", "వస్తాడు", "ఆడుతాడు", "పాడుతాడు", "ఉంది", "మరియు", "కానీ", "మీద", "నేను", "నువ్వు",
        "అతను", "ఆమె", "మేము", "ఇది", "ఏమిటి", "ఎందుకు", "ఎక్కడ", "ధన్యవాదాలు", "ఘంట", "ఝరి",
        "ఠీవి", "ఢంకా", "థాంక్స్", "ఫలం", "భయం", "ఖర్చు", "ఛత్రం", "శరీరం", "షరతు", "ఋషి",
        "ఐదు", "ఒకటి", "ఓడ", "ఔషధం", "జలం", "గణం", "లక్ష", "యాత్ర", "హంస", "బాల",
    ),
}


def native_text(rng, language):
    """Three to ten random words of NATIVE_WORDS[language], with a comma maybe after a few and
    a full stop (the danda in Hindi) or a question mark at the end."""
    words = [_pick(rng, NATIVE_WORDS[language]) for _ in range(rng.integers(3, 11))]
    for k in range(len(words) - 1):
        if rng.random() < 0.1:
            words[k] += ","
    end = "?" if rng.random() < 0.2 else ("।" if language == "hi" else ".")
    return " ".join(words) + end

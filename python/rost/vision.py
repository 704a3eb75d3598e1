"""rost.vision: visual words of frames from cv2 (numpy H x W x 3 uint8 BGR).

    ex = rost.vision.WordExtractor()            # the shipped ORB vocabulary + intensity + hue words
    words, positions = ex(frame)                 # int32 (N,), int32 (N, 2)
    cfg = rost.Config(V=ex.vocabulary_size, frame_width=frame.shape[1], frame_height=frame.shape[0])

rost.vision.Vocabulary.load(path), .default(), .train(frames, words=5000), .save(path).

    r = rost.vision.Mission("diver.mov", K=16).run()   # a mission over frames, as `rost run` plays a file
"""

from . import _rost

if not hasattr(_rost, "vision"):
    raise ImportError("rost.vision: this rost was built without OpenCV (ROST_VISION=OFF)")

Vocabulary = _rost.vision.Vocabulary
WordExtractor = _rost.vision.WordExtractor
Mission = _rost.vision.Mission

__all__ = ["Mission", "Vocabulary", "WordExtractor"]

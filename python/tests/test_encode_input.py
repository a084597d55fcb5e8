"""encode_input: the calibrated classifier encodings of the C++ frame encoder, the masks one
as tools/train.py --input-encoding masks trains on it."""
import numpy as np
import pytest

import shadowsense as ss


def test_masks_are_the_segmenters_shadow_and_contact(sequence):
    calibration = ss.load_calibration(sequence.calibration_path)
    touched = next(i for i in range(len(sequence.images))
                   if ss.Segmenter(calibration).segment(sequence.images[i]).shadow_box)
    frame = sequence.images[touched]
    out = ss.encode_input(frame, "masks", calibration)
    assert out.shape == frame.shape and out.dtype == np.float32
    assert set(np.unique(out).tolist()) <= {0.0, 1.0}
    skin, contact, shadow = out[..., 0], out[..., 1], out[..., 2]  # B, G, R slots
    assert 0.2 < skin.mean() <= 1.0
    assert not (shadow * (1 - skin)).any()  # nothing is segmented off the skin
    assert shadow.sum() > 100
    # The shadow pixels lie in the shadow box the segmenter reports for the frame.
    x, y, w, h = ss.Segmenter(calibration).segment(frame).shadow_box
    inside = shadow[y:y + h, x:x + w].sum()
    assert inside / shadow.sum() >= 0.9
    # The empty skin: next to no shadow.
    empty = ss.encode_input(sequence.images[0], "masks", calibration)
    assert empty[..., 2].sum() < 0.01 * shadow.size
    assert np.array_equal(empty[..., 0], skin)  # the skin test reads the model, not the frame


def test_the_other_calibrated_encodings_and_errors(sequence):
    calibration = ss.load_calibration(sequence.calibration_path)
    frame = sequence.images[0]
    for encoding in ("skin_relative", "darkness_warmth", "darkness_contact"):
        out = ss.encode_input(frame, encoding, calibration)
        assert out.shape == frame.shape and 0.0 <= out.min() and out.max() <= 1.0
    # The combination: darkness_warmth's darkness and skin, the masks' contact plane.
    touched = sequence.images[len(sequence.images) // 2]
    dc = ss.encode_input(touched, "darkness_contact", calibration)
    dw = ss.encode_input(touched, "darkness_warmth", calibration)
    mk = ss.encode_input(touched, "masks", calibration)
    assert np.array_equal(dc[..., [0, 2]], dw[..., [0, 2]])
    assert np.array_equal(dc[..., 1], mk[..., 1])
    with pytest.raises(ValueError, match="input encoding 'colour'"):
        ss.encode_input(frame, "colour", calibration)
    with pytest.raises(ValueError, match="input encoding 'mask'"):
        ss.encode_input(frame, "mask", calibration)
    with pytest.raises(ValueError, match="expected a non-empty C-contiguous HxWx3 uint8"):
        ss.encode_input(frame.astype(np.float32), "masks", calibration)


def test_input_encoder_equals_encode_input_over_a_sequence(sequence):
    """One InputEncoder reused over frames (and a frame of another size) gives exactly what a
    new encoder per call gives: nothing of one frame leaks into the next."""
    calibration = ss.load_calibration(sequence.calibration_path)
    for encoding in ("skin_relative", "darkness_warmth", "masks", "darkness_contact"):
        encoder = ss.InputEncoder(encoding, calibration)
        assert encoder.encoding == encoding
        frames = list(sequence.images) + [np.ascontiguousarray(sequence.images[-1][::2, ::2])]
        frames.append(sequence.images[0])  # back to the first size after the small one
        for frame in frames:
            assert np.array_equal(encoder.encode(frame), ss.encode_input(frame, encoding, calibration))
    with pytest.raises(ValueError, match="input encoding 'colour'"):
        ss.InputEncoder("colour", calibration)
    with pytest.raises(ValueError, match="InputEncoder.encode: the frame has dtype float32"):
        ss.InputEncoder("masks", calibration).encode(sequence.images[0].astype(np.float32))

#!/usr/bin/python3
"""Tests of the model-file tools: densenet_to_model.py rejects bad values with exit status 2
and no traceback, writes version 2 atomically and upgrades version-1 files; train.py accepts a
plain class-per-folder tree and leaves no temporary file.

  /usr/bin/python3 tools/test_model_tools.py        (run by .ci/steps/model_tools.sh)
"""
import os
import resource
import shutil
import struct
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
import densenet_to_model as d2m  # noqa: E402

FIXTURE_V1 = os.path.join(ROOT, "tests", "data", "densenet_tiny.ssdn")
TINY = ["--random-init", "--growth-rate", "2", "--block-config", "1", "1", "--init-features",
        "4", "--num-classes", "3", "--resize", "0", "0", "--crop", "0", "0"]


def read_bytes(path):
    with open(path, "rb") as f:
        return f.read()


def run(script, *args, **kw):
    return subprocess.run([sys.executable, os.path.join(HERE, script), *args],
                          capture_output=True, text=True, **kw)


def grey_tree(root, per_class, nested=False):
    """A plain class-per-folder tree under root: classes dim and lit, per_class flat grey
    40 x 30 images each (dim about 40, lit about 190; every other one in a sub-folder when
    nested)."""
    from PIL import Image
    for k, cls in enumerate(("dim", "lit")):
        for i in range(per_class):
            sub = os.path.join(root, cls, "nested" if nested and i % 2 else "")
            os.makedirs(sub, exist_ok=True)
            v = 40 + 150 * k + i
            Image.new("RGB", (40, 30), (v, v, v)).save(os.path.join(sub, f"{i}.png"))
    return root


class DenseNetToModel(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp()

    def tearDown(self):
        shutil.rmtree(self.dir)

    def out(self, name="m.ssm"):
        return os.path.join(self.dir, name)

    def test_bad_values_exit_2_without_traceback_or_file(self):
        for bad, needle in ((["--std", "0", "0", "0"], "--std 0.0 0.0 0.0: expected finite"),
                            (["--contrast", "nan"], "--contrast nan: expected a finite"),
                            (["--block-config", "0"], "--block-config 0: expected 1..16"),
                            (["--resize", "65536", "65536"], "expected both 0 (skip) or both"),
                            (["--dark-threshold", "-1"], "--dark-threshold -1.0"),
                            (["--brightness", "inf"], "--brightness inf")):
            r = run("densenet_to_model.py", *TINY, *bad, "-o", self.out())
            self.assertEqual(r.returncode, 2, bad)
            self.assertIn(needle, r.stderr)
            self.assertNotIn("Traceback", r.stderr)
            self.assertEqual(os.listdir(self.dir), [], bad)

    def test_writes_version_2_with_the_options(self):
        r = run("densenet_to_model.py", *TINY, "--lighting-normalise", "--dark-threshold", "0.25",
                "-o", self.out())
        self.assertEqual(r.returncode, 0, r.stderr)
        data = read_bytes(self.out())
        self.assertEqual(struct.unpack_from("<I", data, 8)[0], 2)
        at = 8 + 4 + 5 * 4 + 4 + 4 * 2 + 13 * 4  # two dense blocks
        flag, target, dark = struct.unpack_from("<Iff", data, at)
        self.assertEqual((flag, dark), (1, 0.25))
        self.assertAlmostEqual(target, 0.35, places=6)
        self.assertEqual(os.listdir(self.dir), ["m.ssm"])

    def test_upgrade_inserts_the_fields_and_keeps_everything_else(self):
        v1 = read_bytes(FIXTURE_V1)
        self.assertEqual(struct.unpack_from("<I", v1, 8)[0], 1)
        r = run("densenet_to_model.py", "--upgrade", FIXTURE_V1, "--lighting-normalise",
                "-o", self.out())
        self.assertEqual(r.returncode, 0, r.stderr)
        v2 = read_bytes(self.out())
        blocks = struct.unpack_from("<I", v1, 8 + 4 + 5 * 4)[0]
        at = 8 + 4 + 5 * 4 + 4 + 4 * blocks + 13 * 4
        self.assertEqual(len(v2), len(v1) + 12)
        self.assertEqual(v2[12:at], v1[12:at])
        self.assertEqual(struct.unpack_from("<Iff", v2, at)[0], 1)
        self.assertEqual(struct.unpack_from("<Iff", v2, at)[2], 0.0)  # version 1's rule
        self.assertEqual(v2[at + 12:-4], v1[at:-4])
        self.assertEqual(d2m.checksum(v2[:-4]), struct.unpack("<I", v2[-4:])[0])
        # Upgrading again, or a file that is not a model, is a clear error (status 2).
        for src, needle in ((self.out(), "already version 2"), (__file__, "wrong magic")):
            r = run("densenet_to_model.py", "--upgrade", src, "-o", self.out("again.ssm"))
            self.assertEqual(r.returncode, 2)
            self.assertIn(needle, r.stderr)
            self.assertNotIn("Traceback", r.stderr)

    def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(self):
        good = read_bytes(FIXTURE_V1)
        with open(self.out(), "wb") as f:
            f.write(good)
        limit = len(good) // 2

        def small_files():
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
            import signal
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)

        r = run("densenet_to_model.py", "--upgrade", FIXTURE_V1, "-o", self.out(),
                preexec_fn=small_files)
        self.assertNotEqual(r.returncode, 0)
        self.assertNotIn("Traceback", r.stderr)
        self.assertEqual(read_bytes(self.out()), good)
        self.assertEqual(os.listdir(self.dir), ["m.ssm"])


class TrainOnAPlainTree(unittest.TestCase):
    def test_class_per_folder_tree_and_no_temporary_files(self):
        work = tempfile.mkdtemp()
        try:
            tree = grey_tree(os.path.join(work, "tree"), 6, nested=True)
            out = os.path.join(work, "out")
            os.makedirs(out)
            r = run("train.py", tree, "-o", os.path.join(out, "m.ssm"), "--growth-rate", "2",
                    "--block-config", "1", "--init-features", "4", "--resize", "32", "24",
                    "--epochs", "1", "--save-state-dict", os.path.join(out, "m.pt"))
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("8 training and 4 validation images", r.stdout)
            self.assertEqual(sorted(os.listdir(out)), ["m.pt", "m.ssm"])
            data = read_bytes(os.path.join(out, "m.ssm"))
            self.assertEqual(struct.unpack_from("<I", data, 8)[0], 2)
            r = run("train.py", tree, "-o", os.path.join(out, "x.ssm"), "--epochs", "0")
            self.assertEqual(r.returncode, 2)
            self.assertNotIn("Traceback", r.stderr)
        finally:
            shutil.rmtree(work)


class LearningRateSchedule(unittest.TestCase):
    """--lr-schedule: constant is the paper's recipe; cosine starts at --lr and halves by the
    middle epoch."""

    def test_values(self):
        import train
        self.assertEqual([train.epoch_lr(1e-3, "constant", e, 4) for e in (1, 4)], [1e-3, 1e-3])
        self.assertEqual(train.epoch_lr(1e-3, "cosine", 1, 4), 1e-3)
        self.assertAlmostEqual(train.epoch_lr(1e-3, "cosine", 3, 4), 0.5e-3, delta=1e-15)
        last = train.epoch_lr(1e-3, "cosine", 4, 4)
        self.assertAlmostEqual(last, 1e-3 * (1 - 2 ** -0.5) / 2, delta=1e-15)
        self.assertGreater(last, 0.0)

    def test_unknown_schedule_exits_2(self):
        r = run("train.py", "unused", "-o", "unused.ssm", "--lr-schedule", "step")
        self.assertEqual(r.returncode, 2)
        self.assertIn("--lr-schedule", r.stderr)


class WeightAveraging(unittest.TestCase):
    """--swa-from: the running mean of the parameters, and BatchNorm statistics recomputed as
    the plain mean over the batches given."""

    def test_running_mean_of_parameters(self):
        import torch
        import train
        lin = torch.nn.Linear(2, 1)
        avg, n = None, 0
        for v in (1.0, 2.0, 6.0):
            with torch.no_grad():
                lin.weight.fill_(v)
                lin.bias.fill_(-v)
            avg, n = train.average_into(avg, lin, n), n + 1
        self.assertEqual(n, 3)
        self.assertEqual(avg["weight"].tolist(), [[3.0, 3.0]])
        self.assertEqual(avg["bias"].tolist(), [-3.0])

    def test_batch_norm_statistics_are_the_mean_over_the_batches(self):
        import torch
        import train
        net = torch.nn.Sequential(torch.nn.Conv2d(1, 1, 1, bias=False), torch.nn.BatchNorm2d(1))
        with torch.no_grad():
            net[0].weight.fill_(2.0)
        net[1].running_mean.fill_(100.0)  # stale statistics, to be replaced
        batches = [torch.full((2, 1, 2, 2), v) for v in (1.0, 3.0, 8.0)]
        train.recompute_batch_norm(net, batches)
        self.assertAlmostEqual(net[1].running_mean.item(), 2.0 * 4.0, places=5)
        self.assertEqual(net[1].momentum, 0.1)  # restored
        self.assertTrue(net[1].training)

    def test_out_of_range_exits_2(self):
        r = run("train.py", "unused", "-o", "unused.ssm", "--epochs", "4", "--swa-from", "5")
        self.assertEqual(r.returncode, 2)
        self.assertIn("--swa-from 5", r.stderr)
        self.assertNotIn("Traceback", r.stderr)


class Distillation(unittest.TestCase):
    """--teacher: the loss against values worked by hand, a teacher with the student's input is
    used, one with another input or other classes is refused (exit 2, no traceback)."""

    def test_loss_by_hand(self):
        import math
        import torch
        import train
        logits = torch.tensor([[2.0, 0.0], [0.0, 1.0]])
        y = torch.tensor([0, 0])
        teacher = torch.tensor([[0.75, 0.25], [0.5, 0.5]])
        nll = (math.log(1 + math.exp(-2.0)) + math.log(1 + math.exp(1.0))) / 2
        self.assertAlmostEqual(train.distillation_loss(logits, y, teacher, 0.0, 2.0).item(), nll,
                               places=6)
        kl = 0.0  # KL(teacher || softmax(logits / 2)), summed over classes, mean over rows
        for row, t in zip(((1.0, 0.0), (0.0, 0.5)), teacher.tolist()):
            z = math.log(sum(math.exp(v) for v in row))
            kl += sum(ti * (math.log(ti) - (v - z)) for ti, v in zip(t, row))
        kl /= 2
        self.assertAlmostEqual(train.distillation_loss(logits, y, teacher, 1.0, 2.0).item(),
                               4.0 * kl, places=6)
        self.assertAlmostEqual(train.distillation_loss(logits, y, teacher, 0.25, 2.0).item(),
                               0.75 * nll + 0.25 * 4.0 * kl, places=6)

    def test_teachers_mean_at_the_temperature(self):
        import torch
        import train
        a, b = torch.nn.Linear(1, 2), torch.nn.Linear(1, 2)
        with torch.no_grad():
            a.weight.copy_(torch.tensor([[2.0], [0.0]]))
            b.weight.copy_(torch.tensor([[0.0], [2.0]]))
            a.bias.zero_()
            b.bias.zero_()
        p = train.teacher_probabilities([a, b], torch.tensor([[1.0]]), 2.0)
        self.assertTrue(torch.allclose(p, torch.tensor([[0.5, 0.5]]), atol=1e-7))
        p = train.teacher_probabilities([a], torch.tensor([[1.0]]), 2.0)
        self.assertAlmostEqual(p[0, 0].item(), 1 / (1 + torch.exp(torch.tensor(-1.0)).item()),
                               places=6)

    def test_teacher_with_the_students_input_or_refused(self):
        work = tempfile.mkdtemp()
        try:
            tree = grey_tree(os.path.join(work, "tree"), 4)
            tiny = ["--growth-rate", "2", "--block-config", "1", "--init-features", "4",
                    "--epochs", "1"]
            teacher = os.path.join(work, "t.ssm")
            r = run("train.py", tree, "-o", teacher, "--resize", "32", "24", *tiny)
            self.assertEqual(r.returncode, 0, r.stderr)
            r = run("train.py", tree, "-o", os.path.join(work, "s.ssm"), "--resize", "32", "24",
                    "--teacher", teacher, "--teacher", teacher, *tiny)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertTrue(os.path.isfile(os.path.join(work, "s.ssm")))
            for extra, what in ((["--resize", "32", "16"], "resize_height"),
                                (["--resize", "32", "24", "--lighting-normalise"],
                                 "lighting_normalise"),
                                (["--resize", "32", "24", "--classes", "lit,dim"], "classes")):
                r = run("train.py", tree, "-o", os.path.join(work, "x.ssm"), "--teacher", teacher,
                        *extra, *tiny)
                self.assertEqual(r.returncode, 2, what)
                self.assertIn(what, r.stderr)
                self.assertNotIn("Traceback", r.stderr)
            r = run("train.py", tree, "-o", os.path.join(work, "x.ssm"), "--teacher", tree, *tiny)
            self.assertEqual(r.returncode, 2)
            self.assertIn("--teacher", r.stderr)
            self.assertNotIn("Traceback", r.stderr)
            for bad in (["--distill-weight", "1.5"], ["--distill-temperature", "0"]):
                r = run("train.py", tree, "-o", os.path.join(work, "x.ssm"), *bad)
                self.assertEqual(r.returncode, 2, bad)
                self.assertIn(bad[0], r.stderr)
            self.assertFalse(os.path.exists(os.path.join(work, "x.ssm")))
        finally:
            shutil.rmtree(work)


class SkinRelativeEncoding(unittest.TestCase):
    """The skin_relative encoding and the calibration file on the Python side (the C++ side and
    the agreement of the two: tests/test_frame_encoder.cpp)."""

    def test_values_by_hand(self):
        import numpy as np
        import torch
        import train
        m = np.full((2, 3, 3), 0.8, np.float32)  # B, G, R
        m[0, 1] = 0.2                             # not skin (sum 0.6)
        m[0, 2] = (0.05, 0.7, 0.75)               # skin (sum 1.5); B under the floor 0.125
        x = torch.empty(3, 2, 3)                  # R, G, B
        x[0], x[1], x[2] = 255 / 255.0, 64 / 255.0, 128 / 255.0
        e = train.skin_relative(x, m)
        f32 = np.float32
        self.assertEqual(e[0, 0, 0].item(), 1.0)                          # R clipped
        self.assertEqual(e[1, 0, 0].item(), f32(f32(64 / 255.0) / f32(0.8)))
        self.assertEqual(e[:, 0, 1].tolist(), [0.0, 0.0, 0.0])
        self.assertEqual(e[2, 0, 2].item(), 1.0)                          # 0.502 / 0.125 > 1
        self.assertEqual(e[1, 0, 2].item(), f32(f32(64 / 255.0) / f32(0.7)))

    def test_darkness_warmth_by_hand(self):
        # The lit skin at a light level on a reference bin's centre (409.5 / 512), so the
        # reference is the level: lit skin darkness 0 and warmth 0.5, a shadow (x 0.3) darkness
        # 0.7, a contact (green and blue x 0.35) darkness 1 - 1.7 / 3 and warmth 0.825.
        import numpy as np
        import torch
        import train
        m = np.full((12, 12, 3), 0.8, np.float32)  # B, G, R
        m[0] = 0.2                                 # a row that is not skin
        level = 409.5 / 512
        x = torch.from_numpy(m).permute(2, 0, 1).flip(0) * level  # R, G, B
        x[:, 4:7, 1:4] *= 0.3
        x[1:, 8:11, 8:11] *= 0.35
        e = train.darkness_warmth(x, m)
        self.assertLess(e[0, 2, 10].item(), 1e-6)
        self.assertAlmostEqual(e[1, 2, 10].item(), 0.5, places=5)
        self.assertEqual(e[2, 2, 10].item(), 1.0)
        self.assertAlmostEqual(e[0, 5, 2].item(), 0.7, places=5)
        self.assertAlmostEqual(e[0, 9, 9].item(), 1 - 1.7 / 3, places=5)
        self.assertAlmostEqual(e[1, 9, 9].item(), 0.825, places=5)
        self.assertEqual(e[:, 0, 5].tolist(), [0.0, 0.0, 0.0])  # off the skin
        # About half the light (another bin centre): the same maps.
        half = train.darkness_warmth(x * (204.5 / 409.5), m)
        self.assertLess((half - e).abs().max().item(), 1e-5)

    def test_darkness_warmth_takes_no_lighting_normalisation(self):
        r = run("train.py", "unused", "-o", "unused.ssm", "--input-encoding", "darkness_warmth",
                "--lighting-normalise")
        self.assertEqual(r.returncode, 2)
        self.assertIn("takes no --lighting-normalise", r.stderr)

    def test_calibration_file_round_trip_and_damage(self):
        import numpy as np
        import calibration_file as cf
        work = tempfile.mkdtemp()
        try:
            path = os.path.join(work, "c.calib")
            m = np.random.default_rng(1).uniform(0, 2, (5, 7, 3)).astype(np.float32)
            cf.write_calibration(path, m)
            self.assertTrue(np.array_equal(cf.read_empty_skin(path), m))
            data = read_bytes(path)
            for bad, needle in ((data[:-3], "cut"), (data[:-200], "empty-skin block is cut"),
                                (data[:40] + b"X" + data[41:], "checksum mismatch"),
                                (b"hello\n", "not a calibration file")):
                with open(path, "wb") as f:
                    f.write(bad)
                with self.assertRaises(cf.CalibrationFileError) as ctx:
                    cf.read_empty_skin(path)
                self.assertIn(needle, str(ctx.exception))
                self.assertIn(path, str(ctx.exception))
        finally:
            shutil.rmtree(work)

    def test_calibration_file_version_3_carries_the_camera_scale(self):
        import zlib
        import numpy as np
        import calibration_file as cf
        work = tempfile.mkdtemp()
        try:
            path = os.path.join(work, "c.calib")
            m = np.full((3, 4, 3), 0.8, np.float32)
            cf.write_calibration(path, m)
            self.assertEqual(cf.read_px_per_cm(path), 0.0)
            body = read_bytes(path)
            body = body[:body.rfind(b"end ")]

            def v3(line):  # the C++ writer's layout: header 3, px_per_cm before empty_skin
                t = body.replace(b"calibration 2\n", b"calibration 3\n")
                t = t.replace(b"empty_skin ", line + b"empty_skin ", 1)
                return t + b"end %08x\n" % zlib.crc32(t)
            with open(path, "wb") as f:
                f.write(v3(b"px_per_cm 10.9921875\n"))
            self.assertEqual(cf.read_px_per_cm(path), 10.9921875)
            self.assertTrue(np.array_equal(cf.read_empty_skin(path), m))
            for bad in (b"px_per_cm -1\n", b"px_per_cm x\n", b"px_per_cm 1 2\n"):
                with open(path, "wb") as f:
                    f.write(v3(bad))
                with self.assertRaises(cf.CalibrationFileError) as ctx:
                    cf.read_px_per_cm(path)
                self.assertIn("px_per_cm", str(ctx.exception))
        finally:
            shutil.rmtree(work)

    def test_train_writes_version_4_and_needs_the_empty_skin(self):
        import numpy as np
        import calibration_file as cf
        import train
        work = tempfile.mkdtemp()
        try:
            tree = grey_tree(os.path.join(work, "tree"), 6)
            cal = os.path.join(work, "c.calib")
            cf.write_calibration(cal, np.full((30, 40, 3), 0.9, np.float32))
            args = [tree, "--growth-rate", "2", "--block-config", "1", "--init-features", "4",
                    "--resize", "32", "24", "--epochs", "1", "--input-encoding", "skin_relative"]
            out = os.path.join(work, "m.ssm")
            r = run("train.py", *args, "--calibration", cal, "-o", out)
            self.assertEqual(r.returncode, 0, r.stderr)
            data = read_bytes(out)
            self.assertEqual(struct.unpack_from("<I", data, 8)[0], 4)
            at = 8 + 4 + 5 * 4 + 4 + 4 * 1 + 13 * 4 + 12  # one dense block; after the dark rule
            self.assertEqual(struct.unpack_from("<I", data, at)[0], 1)
            self.assertEqual(struct.unpack_from("<I", data, len(data) - 8)[0], 0)  # no int8
            self.assertEqual(d2m.checksum(data[:-4]), struct.unpack("<I", data[-4:])[0])
            self.assertEqual(train.read_model_file(out)[1]["input_encoding"], "skin_relative")
            # Without --calibration a plain tree has no empty_skin/<session>.calib.
            r = run("train.py", *args, "-o", os.path.join(work, "x.ssm"))
            self.assertEqual(r.returncode, 1)
            self.assertIn("needs the empty-skin model of session", r.stderr)
            self.assertNotIn("Traceback", r.stderr)
            self.assertFalse(os.path.exists(os.path.join(work, "x.ssm")))
            # darkness_warmth: code 2, read back by name.
            dw = [a if a != "skin_relative" else "darkness_warmth" for a in args]
            r = run("train.py", *dw, "--calibration", cal, "--contrast", "1", "-o", out)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertEqual(struct.unpack_from("<I", read_bytes(out), at)[0], 2)
            self.assertEqual(train.read_model_file(out)[1]["input_encoding"], "darkness_warmth")
            # tools/model_encoding.py reads the same from the header alone.
            r = run("model_encoding.py", out)
            self.assertEqual((r.returncode, r.stdout), (0, "darkness_warmth\n"), r.stderr)
            r = run("model_encoding.py", os.path.join(HERE, "..", "models", "default.ssm"))
            self.assertEqual((r.returncode, r.stdout), (0, "colour\n"), r.stderr)
            r = run("model_encoding.py", cal)
            self.assertEqual(r.returncode, 2)
            self.assertIn("not a shadowsense model file", r.stderr)
            self.assertNotIn("Traceback", r.stderr)
        finally:
            shutil.rmtree(work)


if __name__ == "__main__":
    unittest.main()

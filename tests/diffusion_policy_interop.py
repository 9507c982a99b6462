#!/usr/bin/python3
"""Checks an exported state_dict against diffusion_policy's ConditionalUnet1D, without torch.

usage: diffusion_policy_interop.py STATE_DICT JSON [PYTHON_STYLE_OUT]

1. Reads STATE_DICT (torch's zip archive: archive/data.pkl plus one file per storage) with the
   standard library's zipfile and pickle, the way torch.load does, resolving torch's tensor
   rebuilding and storage classes to stand-ins.
2. Builds the parameter names and shapes ConditionalUnet1D(input_dim, global_cond_dim,
   diffusion_step_embed_dim, down_dims, kernel_size, n_groups, cond_predict_scale=True) registers,
   from its module structure, and checks the file holds exactly those.
3. With PYTHON_STYLE_OUT: writes the same tensors the way Python's torch.save writes a plain dict
   (protocol 2, _rebuild_tensor_v2, persistent storage ids, storages shared by views, another key
   order), so that the C++ importer is tested on a file it did not write itself.
Exits non-zero with a message on the first mismatch.
"""
import collections
import io
import json
import pickle
import struct
import sys
import types
import zipfile


# ---- stand-ins for the torch names a state_dict pickle refers to ----
class Storage:
    def __init__(self, dtype, key, data=b""):
        self.dtype, self.key, self.data = dtype, key, data


class FakeTensor:
    def __init__(self, storage, offset, size, stride):
        self.storage, self.offset, self.size, self.stride = storage, offset, tuple(size), tuple(stride)

    def values(self):
        n = 1
        for s in self.size:
            n *= s
        floats = struct.unpack("<%df" % (len(self.storage.data) // 4), self.storage.data)
        # contiguous row-major only (what both writers produce)
        return floats[self.offset:self.offset + n]

    def __reduce_ex__(self, protocol):
        return (rebuild_tensor_v2, (self.storage, self.offset, self.size, self.stride, False, collections.OrderedDict()))


def rebuild_tensor_v2(storage, offset, size, stride, requires_grad=False, hooks=None, *rest):
    return FakeTensor(storage, offset, size, stride)


class FloatStorage:  # only the class object is pickled (as a global)
    pass


torch_mod = types.ModuleType("torch")
torch_utils = types.ModuleType("torch._utils")
torch_mod.FloatStorage = FloatStorage
torch_mod._utils = torch_utils
torch_utils._rebuild_tensor_v2 = rebuild_tensor_v2
FloatStorage.__module__, FloatStorage.__qualname__ = "torch", "FloatStorage"
rebuild_tensor_v2.__module__, rebuild_tensor_v2.__qualname__ = "torch._utils", "_rebuild_tensor_v2"
sys.modules["torch"], sys.modules["torch._utils"] = torch_mod, torch_utils


def fail(msg):
    print("FAIL:", msg)
    sys.exit(1)


def read_state_dict(path):
    z = zipfile.ZipFile(path)
    names = z.namelist()
    pkl = [n for n in names if n.endswith("/data.pkl")]
    if len(pkl) != 1:
        fail("%s: no data.pkl in the archive (%s)" % (path, names[:5]))
    root = pkl[0][: -len("data.pkl")]

    class Unpickler(pickle.Unpickler):
        def find_class(self, module, name):
            if (module, name) == ("torch._utils", "_rebuild_tensor_v2"):
                return rebuild_tensor_v2
            if module == "torch" and name.endswith("Storage"):
                return name
            if (module, name) == ("collections", "OrderedDict"):
                return collections.OrderedDict
            if (module, name) == ("torch.jit._pickle", "restore_type_tag"):  # libtorch's typed dicts
                return lambda value, type_str: value
            fail("%s: the pickle refers to %s.%s" % (path, module, name))

        def persistent_load(self, pid):
            kind, storage_type, key, location, numel = pid
            if kind != "storage":
                fail("%s: unknown persistent id %r" % (path, pid))
            if storage_type != "FloatStorage":
                fail("%s: storage %s is %s, not float32" % (path, key, storage_type))
            return Storage(storage_type, key, z.read(root + "data/" + key))

    return Unpickler(io.BytesIO(z.read(pkl[0]))).load()


def expected_shapes(input_dim, global_cond_dim, dsed, down_dims, k, cond_predict_scale=True):
    """ConditionalUnet1D's parameters, name -> shape, from its module structure."""
    p = {}
    cond_dim = dsed + global_cond_dim

    def conv(name, cin, cout, kk):
        p[name + ".weight"], p[name + ".bias"] = (cout, cin, kk), (cout,)

    def linear(name, fin, fout):
        p[name + ".weight"], p[name + ".bias"] = (fout, fin), (fout,)

    def norm(name, c):
        p[name + ".weight"], p[name + ".bias"] = (c,), (c,)

    def res(name, cin, cout):
        conv(name + ".blocks.0.block.0", cin, cout, k)
        norm(name + ".blocks.0.block.1", cout)
        conv(name + ".blocks.1.block.0", cout, cout, k)
        norm(name + ".blocks.1.block.1", cout)
        linear(name + ".cond_encoder.1", cond_dim, 2 * cout if cond_predict_scale else cout)
        if cin != cout:
            conv(name + ".residual_conv", cin, cout, 1)

    linear("diffusion_step_encoder.1", dsed, 4 * dsed)
    linear("diffusion_step_encoder.3", 4 * dsed, dsed)
    dims = [input_dim] + list(down_dims)
    in_out = list(zip(dims[:-1], dims[1:]))
    for i, (din, dout) in enumerate(in_out):
        res("down_modules.%d.0" % i, din, dout)
        res("down_modules.%d.1" % i, dout, dout)
        if i < len(in_out) - 1:
            conv("down_modules.%d.2.conv" % i, dout, dout, 3)
    res("mid_modules.0", dims[-1], dims[-1])
    res("mid_modules.1", dims[-1], dims[-1])
    for i, (din, dout) in enumerate(reversed(in_out[1:])):
        res("up_modules.%d.0" % i, 2 * dout, din)
        res("up_modules.%d.1" % i, din, din)
        # ConvTranspose1d(dim, dim, 4, 2, 1): weight (in, out, k)
        p["up_modules.%d.2.conv.weight" % i], p["up_modules.%d.2.conv.bias" % i] = (din, din, 4), (din,)
    start = down_dims[0]
    conv("final_conv.0.block.0", start, start, k)
    norm("final_conv.0.block.1", start)
    conv("final_conv.1", start, input_dim, 1)
    return p


def write_python_style(path, tensors):
    """torch.save(dict(state_dict), path) as Python 1.13 writes it: archive/data.pkl (protocol 2),
    archive/data/<key> raw little-endian storages, archive/version."""
    # a reversed key order, and every bias shares one storage with its weight (as views of one buffer)
    storages, objs = {}, {}
    for name in reversed(list(tensors)):
        t = tensors[name]
        base = name.rsplit(".", 1)[0]
        if base not in storages:
            storages[base] = Storage("FloatStorage", str(len(storages)), b"")
        s = storages[base]
        offset = len(s.data) // 4
        s.data += struct.pack("<%df" % len(t.values()), *t.values())
        stride, acc = [], 1
        for d in reversed(t.size):
            stride.insert(0, acc)
            acc *= d
        objs[name] = FakeTensor(s, offset, t.size, stride)

    class Pickler(pickle.Pickler):
        def persistent_id(self, obj):
            if isinstance(obj, Storage):
                return ("storage", FloatStorage, obj.key, "cpu", len(obj.data) // 4)
            return None

    buf = io.BytesIO()
    Pickler(buf, protocol=2).dump(objs)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as z:
        z.writestr("archive/data.pkl", buf.getvalue())
        for s in storages.values():
            z.writestr("archive/data/" + s.key, s.data)
        z.writestr("archive/version", "3\n")


def main():
    if len(sys.argv) not in (3, 4):
        fail(__doc__)
    sd = read_state_dict(sys.argv[1])
    meta = json.load(open(sys.argv[2]))
    if not isinstance(sd, dict):
        fail("the state_dict is a %s, not a dict" % type(sd).__name__)
    want = expected_shapes(len(meta["action"]["scale"]), len(meta["obs"]["scale"]), meta["diffusion_step_embed_dim"],
                           meta["down_dims"], meta["kernel_size"])
    missing, extra = sorted(set(want) - set(sd)), sorted(set(sd) - set(want))
    if missing or extra:
        fail("names differ from ConditionalUnet1D's: missing %s, unexpected %s" % (missing[:5], extra[:5]))
    for name, shape in want.items():
        if sd[name].size != shape:
            fail("%s has shape %s, ConditionalUnet1D's is %s" % (name, sd[name].size, shape))
    n = sum(len(t.values()) for t in sd.values())
    print("ok: %d tensors, %d parameters, names and shapes of diffusion_policy's ConditionalUnet1D" % (len(sd), n))
    if len(sys.argv) == 4:
        write_python_style(sys.argv[3], sd)
        print("wrote", sys.argv[3], "in Python torch.save's layout")


main()

"""Errors: ConfigError with file:line:col and the key path, and no C++ exception reaching Python as a crash."""
import os

import pytest

import varbo


def test_config_error_from_file(tmp_path):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("task: {type: branin}\nbudget: 5\nalgorithm:\n  type: bo\n  acquisition: {type: ei, xii: 0.1}\n")
    with pytest.raises(varbo.ConfigError) as e:
        varbo.Study.create(tmp_path / "s.db", str(cfg))
    err = e.value
    assert isinstance(err, ValueError) and isinstance(err, varbo.Error)
    assert err.file == str(cfg) and err.line == 5 and err.column >= 1
    assert err.key == "algorithm.acquisition.xii" and "did you mean 'xi'" in str(err)
    assert not os.path.exists(tmp_path / "s.db")  # nothing written


def test_config_error_from_dict_and_string(tmp_path):
    with pytest.raises(varbo.ConfigError) as e:
        varbo.Study.create(tmp_path / "a.db", {"task": {"type": "branin"}, "budget": -1})
    assert e.value.key == "budget" and e.value.file == "<config dict>"
    with pytest.raises(varbo.UnknownComponentError) as e:
        varbo.Study.create(tmp_path / "b.db", "task: {type: nosuch}\n")
    assert e.value.file == "<config string>" and e.value.line == 1
    with pytest.raises(varbo.ConfigError):  # a YAML syntax error
        varbo.Study.create(tmp_path / "c.db", "task: {type: branin\nbudget: [\n")
    with pytest.raises(varbo.ConfigError, match="missing.yaml"):  # a .yaml path that does not exist
        varbo.Study.create(tmp_path / "d.db", str(tmp_path / "missing.yaml"))
    with pytest.raises(TypeError):
        varbo.Study.create(tmp_path / "e.db", 42)


def test_plugins_and_describe():
    names = {c["name"] for c in varbo.plugins()}
    assert {"bo", "gp", "vhgp", "ei", "branin"} <= names
    kinds = {c["kind"] for c in varbo.plugins("surrogate")}
    assert kinds == {"surrogate"}
    d = varbo.describe("ei")
    assert d["kind"] == "acquisition" and any(o["name"] == "xi" for o in d["options"])
    assert any(o["name"] == "budget" for o in varbo.describe("study")["options"])
    with pytest.raises(varbo.UnknownComponentError, match="did you mean 'ei'"):
        varbo.describe("eii")
    with pytest.raises(varbo.ConfigError):
        varbo.plugins("nokind")


def test_load_plugin_errors(tmp_path):
    with pytest.raises(varbo.InputError):
        varbo.load_plugin(str(tmp_path / "libvarbo_missing.so"))
    junk = tmp_path / "libvarbo_junk.so"
    junk.write_bytes(b"not an ELF file at all")
    with pytest.raises(varbo.PluginLoadError, match="libvarbo_junk.so"):
        varbo.load_plugin(str(junk))
    assert "libvarbo_junk" not in os.environ.get("VARBO_PLUGIN_PATH", "")


def test_set_log_level():
    varbo.set_log_level("info")
    varbo.set_log_level("warn")  # the default after import
    with pytest.raises(varbo.InputError):
        varbo.set_log_level("loud")

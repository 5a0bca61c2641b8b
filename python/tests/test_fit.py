"""varbo.fit: the numbers of `varbo fit` (JSON) to 1e-12, and predictions against finite differences."""
import json

import numpy as np
import pytest

import varbo
from conftest import run_cli


def data(n=25, d=2, seed=0, noise=0.05):
    rng = np.random.default_rng(seed)
    X = rng.uniform(0, 1, (n, d))
    y = np.sin(6 * X[:, 0]) + X[:, 1] ** 2 + noise * (1 + 3 * X[:, 0]) * rng.standard_normal(n)
    return X, y


def write_csv(path, X, y=None):
    cols = [f"x{i + 1}" for i in range(X.shape[1])] + ([] if y is None else ["y"])
    rows = [",".join(cols)]
    for i in range(X.shape[0]):
        vals = list(X[i]) + ([] if y is None else [y[i]])
        rows.append(",".join(repr(float(v)) for v in vals))
    path.write_text("\n".join(rows) + "\n")


def close(a, b, tol=1e-12):
    return abs(a - b) <= tol * max(1.0, abs(a), abs(b))


@pytest.mark.parametrize("surrogate", ["{type: gp, restarts: 2}",
                                       "{type: vhgp, restarts: 1, noise_model: heteroscedastic}"])
def test_fit_equals_varbo_fit(tmp_path, surrogate):
    X, y = data()
    P = np.random.default_rng(1).uniform(0, 1, (7, 2))
    write_csv(tmp_path / "d.csv", X, y)
    write_csv(tmp_path / "p.csv", P)
    (tmp_path / "s.yaml").write_text(surrogate + "\n")
    cli = json.loads(run_cli("fit", "--surrogate", tmp_path / "s.yaml", "--data", tmp_path / "d.csv", "--predict",
                             tmp_path / "p.csv", "--seed", 5, "--threads", 2, check=False).stdout)
    model = varbo.fit(surrogate, X, y, seed=5, threads=2)
    assert model.surrogate == cli["surrogate"] and model.ok == cli["ok"] and model.optimized == cli["optimized"]
    for key in ("objective", "objective_without_prior", "log_prior"):
        assert close(getattr(model, key), cli[key]), key
    assert set(model.hyperparameters) == set(cli["hyperparameters"])
    for k, v in cli["hyperparameters"].items():
        assert close(model.hyperparameters[k], v), k
    for k, v in cli.get("state", {}).items():
        np.testing.assert_allclose(model.state[k], v, rtol=1e-12, atol=1e-12)
    pred = model.predict(P)
    for i, p in enumerate(cli["predictions"]):
        assert close(pred.mean[i], p["mean"]) and close(pred.variance[i], p["variance"])
        assert close(pred.latent_var[i], p["latent_var"])
        assert close(pred.log_noise_mean[i], p["log_noise_mean"]) and close(pred.log_noise_var[i], p["log_noise_var"])


def test_the_same_file_as_varbo_fit(tmp_path):
    """A study file's algorithm.surrogate is the model (as `varbo fit --surrogate study.yaml`)."""
    X, y = data(12)
    (tmp_path / "study.yaml").write_text("task: branin\nalgorithm: {type: bo, surrogate: {type: gp, restarts: 1}}\n")
    m = varbo.fit(str(tmp_path / "study.yaml"), X, y)
    assert m.surrogate in ("gp", "gp/gp") and "restarts: 1" in m.config


@pytest.mark.parametrize("surrogate", ["gp", "{type: vhgp, restarts: 1, noise_model: heteroscedastic}"])
def test_gradients_match_finite_differences(surrogate):
    X, y = data(20)
    m = varbo.fit(surrogate, X, y, seed=2)
    P = np.array([[0.3, 0.6], [0.71, 0.2]])
    p = m.predict(P, gradients=True)
    h = 1e-6
    for j in range(2):
        E = np.zeros(2)
        E[j] = h
        up, dn = m.predict(P + E), m.predict(P - E)
        for name, d in (("mean", p.d_mean), ("latent_var", p.d_latent_var), ("noise_var", p.d_noise_var)):
            fd = (getattr(up, name) - getattr(dn, name)) / (2 * h)
            np.testing.assert_allclose(d[:, j], fd, rtol=1e-5, atol=1e-7, err_msg=f"{name} d/dx{j + 1}")


def test_condition_only_reproduces_the_fit():
    """optimize=False at the fitted hyperparameters gives the fitted model back (varbo fit --no-optimize)."""
    X, y = data(15)
    m = varbo.fit("gp", X, y, seed=3)
    c = varbo.fit({"type": "gp", "hyperparameters": m.hyperparameters}, X, y, optimize=False)
    assert not c.optimized and c.objective == pytest.approx(m.objective, rel=1e-9)
    P = np.random.default_rng(4).uniform(0, 1, (5, 2))
    np.testing.assert_allclose(c.predict(P).mean, m.predict(P).mean, rtol=1e-9)


def test_one_dimensional_inputs():
    x = np.linspace(0, 1, 8)
    m = varbo.fit("gp", x, np.cos(3 * x))
    assert m.dim == 1 and m.predict(x).mean.shape == (8,)
    np.testing.assert_allclose(m.predict(x).mean, np.cos(3 * x), atol=0.05)


def test_fit_errors():
    X, y = data(10)
    with pytest.raises(varbo.ConfigError) as e:
        varbo.fit({"type": "gp", "restartz": 2}, X, y)
    assert e.value.key == "restartz" and e.value.file == "<surrogate dict>" and e.value.line >= 1
    with pytest.raises(varbo.UnknownComponentError):
        varbo.fit("nosuchmodel", X, y)
    with pytest.raises(ValueError, match="rows"):
        varbo.fit("gp", X, y[:-1])
    bad = y.copy()
    bad[3] = np.nan
    with pytest.raises(varbo.InputError, match="row 3"):
        varbo.fit("gp", X, bad)
    m = varbo.fit("gp", X, y)
    with pytest.raises(varbo.InputError, match="columns"):
        m.predict(np.zeros((2, 3)))

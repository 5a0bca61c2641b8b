#!/usr/bin/env python3
"""Red-team probes of the Python API (docs/python.md, "Red-team pass (py11)"): each probe runs in its own
interpreter (a crash or hang cannot hide the others), with a 2 GB address-space limit and a timeout.

    PYTHONPATH=build/python /usr/bin/python3 scripts/red_team/probe_python.py [substring]

A probe passes when its code runs through (its own asserts hold) or raises one of the expected exception types,
and the message contains every required word. Anything else — a signal, a timeout, another exception type, a
message that names nothing — fails.
"""
import os
import subprocess
import sys
import time

PRE = r'''
import os, sys, math, signal, threading, time, copy, pickle, tempfile, hashlib, resource, warnings
resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))
import numpy as np, varbo
# A background shell starts children with SIGINT ignored; Python then keeps it ignored. Ctrl-C probes need it.
signal.signal(signal.SIGINT, signal.default_int_handler)
T = tempfile.mkdtemp(prefix="probe-")
import atexit, shutil
atexit.register(shutil.rmtree, T, True)
CFG = "task: {type: branin}\nbudget: 8\nseed: 1\nalgorithm: {type: random}\n"
def mk(name="s.db", cfg=CFG): return varbo.Study.create(os.path.join(T, name), cfg)
def digest(p): return hashlib.sha256(open(p, "rb").read()).hexdigest()
SP = {"x": (-1.0, 1.0), "y": (0.0, 2.0)}
def q(p): return (p["x"] - 0.3) ** 2 + (p["y"] - 1) ** 2
RND = {"algorithm": {"type": "random"}}
MIN = dict(space=SP, budget=6, seed=1)
'''

# (category, name, code, expected exception names or None (must run through), words the message must contain)
P = []
def probe(cat, name, code, expect=None, words=()):
    P.append((cat, name, code, expect, words))

# ---- A. opening and creating studies ----
probe("A", "create(None, cfg)", "varbo.Study.create(None, CFG)", ("TypeError",), ("path",))
probe("A", "create(123, cfg)", "varbo.Study.create(123, CFG)", ("TypeError",), ("path",))
probe("A", "create(path, None)", "mk('a.db', None)", ("TypeError",), ("config",))
probe("A", "open nonexistent", "varbo.Study.open(os.path.join(T, 'nope.db'))", ("InputError",), ("nope.db",))
probe("A", "open directory", "varbo.Study.open(T)", ("InputError",), ("probe-",))
probe("A", "open non-SQLite file",
      "p=os.path.join(T,'junk.db'); open(p,'w').write('hello world\\n'*10); d=digest(p)\n"
      "try: varbo.Study.open(p)\nfinally: assert digest(p)==d, 'file changed'", ("InputError",), ("junk.db",))
probe("A", "open empty file",
      "p=os.path.join(T,'empty.db'); open(p,'w').close()\n"
      "try: varbo.Study.open(p)\nfinally: assert os.path.getsize(p)==0, 'empty file written'", ("InputError",), ("empty.db",))
probe("A", "open postgresql URL to nowhere (<20 s)",
      "t=time.time()\ntry: varbo.Study.open('postgresql://nobody@127.0.0.1:9/nodb')\n"
      "finally: assert time.time()-t < 20, 'slow'", ("InputError", "Error"), ("postgres",))
probe("A", "create over existing study keeps it",
      "s=mk(); s.tell(s.ask()[0], 1.0); p=s.location; d=digest(p)\n"
      "try: mk()\nfinally: assert digest(p)==d", ("InputError",), ("s.db",))
probe("A", "create in missing directory", "mk('no/such/dir/s.db')", ("InputError",), ("no/such/dir",))
probe("A", "create with empty config string", "mk('e.db', '')", ("ConfigError",), ())
probe("A", "bad key, YAML with position, no file",
      "try: mk('k.db', CFG + 'budgett: 3\\n')\nfinally: assert not os.path.exists(os.path.join(T,'k.db'))",
      ("ConfigError",), ("budgett", ":5:"))
probe("A", "config dict with non-string key", "mk('n.db', {'task': {'type': 'branin'}, 1: 2})", ("ConfigError", "TypeError"), ("1",))
probe("A", "config dict with tuple key", "mk('n.db', {'task': {'type': 'branin'}, (1, 2): 2})", ("TypeError",), ("config",))
probe("A", "config dict with NaN budget", "mk('n.db', {'task': {'type': 'branin'}, 'budget': float('nan')})", ("ConfigError",), ("budget",))
probe("A", "deeply nested dict config", "d={}\nc=d\nfor i in range(5000): c['a']={}; c=c['a']\nmk('d.db', {'task': {'type': 'branin'}, 'x': d})",
      ("ConfigError", "TypeError", "ValueError"), ())
probe("A", "deeply nested YAML string (100k [)", "mk('d.db', 'task: {type: branin}\\nx: ' + '['*100000)", ("ConfigError",), ())
probe("A", "YAML alias bomb", "lines=['a0: &a0 [x, x, x, x, x, x, x, x, x, x]']\n"
      "for i in range(1, 12): lines.append(f'a{i}: &a{i} [' + ', '.join([f'*a{i-1}']*10) + ']')\n"
      "mk('b.db', 'task: {type: branin}\\n' + '\\n'.join(lines) + '\\n')", ("ConfigError",), ())
probe("A", "seed out of range in config", "mk('n.db', 'task: {type: branin}\\nseed: -1\\n')", ("ConfigError",), ("seed",))
probe("A", "huge budget in config", "s=mk('h.db', 'task: {type: branin}\\nbudget: 1000000000000\\nalgorithm: {type: random}\\n'); assert len(s.ask(2))==2", None)
probe("A", "two Study objects on one file",
      "a=mk(); b=varbo.Study.open(a.location); ta=a.ask()[0]; tb=b.ask()[0]; assert ta.id!=tb.id\n"
      "a.tell(tb, 1.0); b.tell(ta, 2.0); assert len([t for t in b.trials(as_frame=False) if t.state=='complete'])==2", None)

# ---- B. ask/tell argument types ----
probe("B", "ask(-1)", "mk().ask(-1)", ("ValueError",), ("ask",))
probe("B", "ask('2')", "mk().ask('2')", ("TypeError",), ("n",))
probe("B", "ask(2.5)", "mk().ask(2.5)", ("TypeError",), ("n",))
probe("B", "ask(None)", "mk().ask(None)", ("TypeError",), ("n",))
probe("B", "ask(True)", "mk().ask(True)", ("TypeError",), ("n",))
probe("B", "ask(np.int64(2))", "assert len(mk().ask(np.int64(2)))==2", None)
probe("B", "ask(10**30)", "mk().ask(10**30)", ("ValueError", "OverflowError"), ("n",))
probe("B", "ask after budget", "s=mk()\nfor t in s.ask(8): s.tell(t, 1.0)\nassert s.ask()==[]", None)
probe("B", "tell(t, None)", "s=mk(); s.tell(s.ask()[0], None)", ("TypeError",), ("cost",))
probe("B", "tell(t, '1.5')", "s=mk(); s.tell(s.ask()[0], '1.5')", ("TypeError",), ("cost",))
probe("B", "tell(t, np.float32)", "s=mk(); t=s.ask()[0]; s.tell(t, np.float32(1.5)); assert s.best().cost==1.5", None)
probe("B", "tell(t, np.array([1.5]))", "s=mk(); t=s.ask()[0]; s.tell(t, np.array([1.5])); assert s.best().cost==1.5", None)
probe("B", "tell(t, np.array([1,2]))", "s=mk(); s.tell(s.ask()[0], np.array([1.0, 2.0]))", ("TypeError", "InputError"), ("cost",))
probe("B", "tell(t, nan)", "s=mk(); s.tell(s.ask()[0], float('nan'))", ("InputError",), ("fail",))
probe("B", "tell(t, -inf)", "s=mk(); s.tell(s.ask()[0], -math.inf)", ("InputError",), ())
probe("B", "tell(t, 1+2j)", "s=mk(); s.tell(s.ask()[0], 1+2j)", ("TypeError",), ("cost",))
probe("B", "tell(t, 10**400)", "s=mk(); s.tell(s.ask()[0], 10**400)", ("InputError", "OverflowError", "ValueError"), ("cost",))
probe("B", "tell twice", "s=mk(); t=s.ask()[0]; s.tell(t, 1.0); s.tell(t, 2.0)", ("InputError",), ("trial 0",))
probe("B", "tell unknown id", "s=mk(); s.ask(); s.tell(999, 1.0)", ("InputError",), ("999",))
probe("B", "tell(True, 1.0)", "s=mk(); s.ask(); s.tell(True, 1.0)", ("TypeError",), ("Trial",))
probe("B", "tell(2**70, 1.0)", "s=mk(); s.ask(); s.tell(2**70, 1.0)", ("InputError", "ValueError"), ("id",))
probe("B", "tell({'cost': None})", "s=mk(); s.tell(s.ask()[0], {'cost': None})", ("TypeError",), ("cost",))
probe("B", "tell components bad value", "s=mk(); s.tell(s.ask()[0], 1.0, {'a': 'x'})", ("InputError",), ("'a'",))
probe("B", "tell components list", "s=mk(); s.tell(s.ask()[0], 1.0, [('a', 1.0)])", ("InputError", "TypeError"), ("components",))
probe("B", "tell components NaN", "s=mk(); s.tell(s.ask()[0], 1.0, {'a': float('nan')})", ("InputError",), ("a",))
probe("B", "fail after tell", "s=mk(); t=s.ask()[0]; s.tell(t, 1.0); s.fail(t, 'x')", ("InputError",), ())
probe("B", "tell_point wrong length", "mk().tell_point([1.0, 2.0, 3.0], 1.0)", ("InputError",), ("2",))
probe("B", "tell_point 2-D", "mk().tell_point([[1.0, 2.0]], 1.0)", ("InputError",), ("1-D",))
probe("B", "tell_point empty", "mk().tell_point([], 1.0)", ("InputError",), ())
probe("B", "tell_point NaN", "mk().tell_point([float('nan'), 1.0], 1.0)", ("InputError",), ())
probe("B", "tell_point out of bounds", "mk().tell_point([100.0, 1.0], 1.0)", ("InputError",), ())
probe("B", "tell_point object dtype", "mk().tell_point(np.array(['a', 1.0], dtype=object), 1.0)", ("InputError", "ValueError", "TypeError"), ("tell_point",))
probe("B", "tell_point strided", "s=mk(); a=np.array([1.0, 9.0, 2.0, 9.0])[::2]; i=s.tell_point(a, 1.0)\n"
      "assert list(s.trials(as_frame=False)[-1].x)==[1.0, 2.0]", None)
probe("B", "tell_point float32 array", "s=mk(); s.tell_point(np.array([1.0, 2.0], dtype=np.float32), 1.0)", None)
probe("B", "tell_point dict numpy values", "s=mk(); s.tell_point({'x1': np.float32(1.0), 'x2': np.int64(3)}, 1.0)", None)
probe("B", "tell_point dict None value", "mk().tell_point({'x1': None, 'x2': 1.0}, 1.0)", ("InputError",), ("x1",))
probe("B", "tell_point cost NaN", "mk().tell_point([1.0, 2.0], float('nan'))", ("InputError",), ())
probe("B", "select(nan)", "s=mk(); [s.tell(t, 1.0 + t.id) for t in s.ask(4)]; s.select(float('nan'))", ("InputError", "ValueError"), ("kappa",))
probe("B", "select('a')", "s=mk(); s.select('a')", ("TypeError", "ValueError"), ("kappa",))
probe("B", "abandon(None)", "mk().abandon(None)", ("TypeError",), ("older_than",))
probe("B", "abandon(-1)", "s=mk(); s.ask(); s.abandon(-1.0)", ("InputError",), ("age",))
probe("B", "heartbeat(None)", "mk().heartbeat(None)", ("TypeError",), ("state",))
probe("B", "trial of another study, same id", "a=mk(); b=mk('b.db'); ta=a.ask()[0]; b.ask(); b.tell(ta, 1.0)", ("InputError",), ("s.db",))
probe("B", "trial from another study", "a=mk(); b=mk('b.db'); ta=a.ask(3)[-1]; b.ask(); b.tell(ta, 1.0)", ("InputError",), ())

# ---- C. minimize ----
for nm, ret, word in [("None", "None", "None"), ("str", "'abc'", "abc"), ("array size 2", "np.array([1.0, 2.0])", "array"),
                      ("complex", "1+2j", "complex"), ("huge int", "10**400", "int"), ("NaN", "float('nan')", "NaN"),
                      ("inf", "math.inf", "inf"), ("bool", "True", "bool"), ("list", "[1.0]", "list")]:
    probe("C", f"fun returns {nm}",
          f"r=varbo.minimize(lambda p: {ret}, RND, **MIN)\n"
          f"assert r.failed==6, r.failed\nassert all(t.state=='failed' for t in r.trials)\n"
          f"assert {word!r}.lower() in r.trials[0].error.lower(), r.trials[0].error", None)
probe("C", "fun returns np.array size 1", "r=varbo.minimize(lambda p: np.array([1.5]), RND, **MIN); assert r.fun==1.5 and r.failed==0", None)
probe("C", "fun returns np.float32", "r=varbo.minimize(lambda p: np.float32(q(p)), RND, **MIN); assert r.failed==0", None)
probe("C", "fun raises: failed trial with reason",
      "def f(p): raise ValueError('sensor broke')\nr=varbo.minimize(f, RND, **MIN)\nassert r.failed==6 and 'ValueError: sensor broke' in r.trials[0].error", None)
probe("C", "fun not callable", "varbo.minimize(3, SP, budget=3)", ("TypeError",), ("fun",))
probe("C", "budget='10'", "varbo.minimize(q, SP, budget='10')", ("TypeError",), ("budget",))
probe("C", "budget=2.5", "varbo.minimize(q, SP, budget=2.5)", ("TypeError",), ("budget",))
probe("C", "budget=True", "varbo.minimize(q, SP, budget=True)", ("TypeError",), ("budget",))
probe("C", "budget=-1", "varbo.minimize(q, SP, budget=-1)", ("ValueError",), ("budget",))
probe("C", "budget=0", "varbo.minimize(q, SP, budget=0)", ("ValueError",), ("budget",))
probe("C", "budget=np.int64(4)", "r=varbo.minimize(q, SP, budget=np.int64(4), seed=1); assert r.evaluations==4", None)
probe("C", "budget=10**30", "varbo.minimize(q, SP, budget=10**30)", ("ValueError", "OverflowError"), ("budget",))
probe("C", "seed=-1", "varbo.minimize(q, SP, budget=3, seed=-1)", ("ValueError",), ("seed",))
probe("C", "seed=2**64", "varbo.minimize(q, SP, budget=3, seed=2**64)", ("ValueError", "OverflowError"), ("seed",))
probe("C", "seed=1.5", "varbo.minimize(q, SP, budget=3, seed=1.5)", ("TypeError",), ("seed",))
probe("C", "seed=np.uint64(2**63)", "varbo.minimize(q, SP, budget=3, seed=np.uint64(2**63))", None)
probe("C", "threads=0", "varbo.minimize(q, SP, budget=3, seed=1, threads=0)", None)
probe("C", "threads=-1", "varbo.minimize(q, SP, budget=3, seed=1, threads=-1)", ("ValueError",), ("threads",))
probe("C", "threads='2'", "varbo.minimize(q, SP, budget=3, seed=1, threads='2')", ("TypeError",), ("threads",))
probe("C", "space NaN bound", "varbo.minimize(q, {'x': (float('nan'), 1.0)}, budget=3)", ("ConfigError",), ("x",))
probe("C", "space inf bound", "varbo.minimize(q, {'x': (0.0, math.inf)}, budget=3)", ("ConfigError",), ("x",))
probe("C", "space low > high", "varbo.minimize(q, {'x': (1.0, 0.0)}, budget=3)", ("ConfigError",), ())
probe("C", "space str bounds", "varbo.minimize(q, {'x': ('0', '1')}, budget=3)", ("ConfigError",), ("x",))
probe("C", "space empty dict", "varbo.minimize(q, {}, budget=3)", ("ConfigError",), ("space",))
probe("C", "space numpy (2,2) array", "r=varbo.minimize(lambda p: p['x1']**2+p['x2']**2, np.array([[-1.0, 1.0], [-1.0, 1.0]]), budget=3, seed=1); assert r.evaluations==3", None)
probe("C", "space=[] list", "varbo.minimize(q, space=[], budget=3)", ("ConfigError",), ("space",))
probe("C", "space bounds numpy scalars", "r=varbo.minimize(q, {'x': (np.float32(-1), np.int64(1)), 'y': (0, 2)}, budget=3, seed=1)", None)
probe("C", "deterministic for a seed",
      "a=varbo.minimize(q, SP, budget=8, seed=5); b=varbo.minimize(q, SP, budget=8, seed=5)\n"
      "assert [tuple(t.x) for t in a.trials]==[tuple(t.x) for t in b.trials]", None)
probe("C", "output is a file", "p=os.path.join(T,'f'); open(p,'w').write('x')\nvarbo.minimize(q, SP, budget=3, output=p)", ("InputError",), ("f",))
probe("C", "callback raises -> re-raised",
      "def cb(t): raise RuntimeError('stop here')\nvarbo.minimize(q, SP, budget=5, callback=cb)", ("RuntimeError",), ("stop here",))
probe("C", "callback True stops", "r=varbo.minimize(q, SP, budget=6, seed=1, callback=lambda t: True); assert r.evaluations==1", None)
probe("C", "callback not callable", "varbo.minimize(q, SP, budget=3, callback=3)", ("TypeError",), ("callback",))
probe("C", "resume a folder holding another space",
      "o=os.path.join(T,'run'); varbo.minimize(q, SP, budget=3, seed=1, output=o)\n"
      "varbo.minimize(q, {'z': (0.0, 1.0)}, budget=4, seed=1, output=o, resume=True)", ("ConfigError", "InputError"), ())

# ---- D. fit / predict ----
XY = "X=np.random.default_rng(0).uniform(size=(10,2)); y=X.sum(1)\n"
probe("D", "fit y wrong length", XY + "varbo.fit('gp', X, y[:5])", ("InputError",), ("y",))
probe("D", "fit empty X", "varbo.fit('gp', np.zeros((0,2)), [])", ("InputError",), ())
probe("D", "fit NaN in X", XY + "X[3,1]=np.nan; varbo.fit('gp', X, y)", ("InputError",), ("row 3",))
probe("D", "fit object dtype X", XY + "Xo=X.astype(object); Xo[0,0]='a'; varbo.fit('gp', Xo, y)", ("InputError", "ValueError", "TypeError"), ("X",))
probe("D", "fit 3-D X", XY + "varbo.fit('gp', X.reshape(10,2,1), y)", ("InputError",), ("2-D",))
probe("D", "fit strided X", XY + "m=varbo.fit('gp', np.asfortranarray(X)[:, ::1], y, optimize=False); m2=varbo.fit('gp', X, y, optimize=False)\n"
      "assert np.allclose(m.predict(X).mean, m2.predict(X).mean)", None)
probe("D", "fit seed=-1", XY + "varbo.fit('gp', X, y, seed=-1)", ("ValueError",), ("seed",))
probe("D", "fit seed=1.5", XY + "varbo.fit('gp', X, y, seed=1.5)", ("TypeError",), ("seed",))
probe("D", "fit threads=-1", XY + "varbo.fit('gp', X, y, threads=-1)", ("ValueError",), ("threads",))
probe("D", "fit bad surrogate", XY + "varbo.fit({'type': 'gp', 'kernal': 1}, X, y)", ("ConfigError",), ("kernal",))
probe("D", "predict wrong columns", XY + "varbo.fit('gp', X, y, optimize=False).predict(np.zeros((3, 3)))", ("InputError",), ("3",))
probe("D", "predict NaN", XY + "varbo.fit('gp', X, y, optimize=False).predict([[np.nan, 0.0]])", ("InputError",), ("NaN",))
probe("D", "predict empty", XY + "p=varbo.fit('gp', X, y, optimize=False).predict(np.zeros((0, 2))); assert p.mean.shape==(0,)", None)
probe("D", "predict str", XY + "varbo.fit('gp', X, y, optimize=False).predict('abc')", ("InputError", "ValueError", "TypeError"), ("X",))
probe("D", "predict 1-D of wrong length", XY + "varbo.fit('gp', X, y, optimize=False).predict([1.0, 2.0, 3.0])", ("InputError",), ("column",))
probe("D", "fit constant y", "X=np.random.default_rng(0).uniform(size=(10,2)); m=varbo.fit('gp', X, np.ones(10)); assert np.all(np.isfinite(m.predict(X).mean))", None)
probe("D", "fit duplicated X rows", "X=np.ones((10,2)); m=varbo.fit('gp', X, np.arange(10.0)); p=m.predict(X); assert np.all(np.isfinite(p.mean))", None, ())

# ---- E. threads, re-entrancy, signals ----
probe("E", "4 threads ask/tell one study",
      "s=mk('t.db', 'task: {type: branin}\\nbudget: 40\\nseed: 1\\nalgorithm: {type: random}\\n'); errs=[]\n"
      "def w():\n  try:\n    for _ in range(10):\n      for t in s.ask(): s.tell(t, 1.0)\n  except Exception as e: errs.append(e)\n"
      "th=[threading.Thread(target=w) for _ in range(4)]; [x.start() for x in th]; [x.join() for x in th]\n"
      "assert not errs, errs; assert sum(t.state=='complete' for t in s.trials(as_frame=False))==40", None)
probe("E", "re-entrant minimize inside fun",
      "def f(p):\n  r=varbo.minimize(q, SP, budget=3, seed=2)\n  return r.fun + p['x']**2\n"
      "r=varbo.minimize(f, RND, **MIN); assert r.failed==0, [t.error for t in r.trials]", None)
probe("E", "Study ask/tell inside fun",
      "s=mk()\ndef f(p):\n  t=s.ask()[0]; s.tell(t, 1.0); return q(p)\nr=varbo.minimize(f, RND, **MIN); assert r.failed==0", None)
probe("E", "raise_signal(SIGINT) in fun -> KeyboardInterrupt, study consistent",
      "o=os.path.join(T,'ki'); n=[0]\ndef f(p):\n  n[0]+=1\n  if n[0]==3: signal.raise_signal(signal.SIGINT)\n  return q(p)\n"
      "try:\n  varbo.minimize(f, SP, budget=6, seed=1, output=o)\nexcept KeyboardInterrupt: pass\nelse: raise AssertionError('no KeyboardInterrupt')\n"
      "s=varbo.Study.open(o+'/study.db'); st=[t.state for t in s.trials(as_frame=False)]; assert st[:2]==['complete','complete'] and 'pending' not in st, st\n"
      "r=varbo.minimize(q, SP, budget=6, seed=1, output=o, resume=True); assert r.evaluations==6, r.evaluations", None)
probe("E", "SIGINT from a thread while fun sleeps (prompt)",
      "threading.Timer(1.0, lambda: os.kill(os.getpid(), signal.SIGINT)).start(); t=time.time()\n"
      "try:\n  varbo.minimize(lambda p: time.sleep(30) or 1.0, SP, budget=3, seed=1)\nexcept KeyboardInterrupt: pass\n"
      "assert time.time()-t < 5, time.time()-t", None)
probe("E", "SIGINT during long C++ work (prompt)",
      "threading.Timer(3.0, lambda: os.kill(os.getpid(), signal.SIGINT)).start(); t=time.time()\n"
      "try:\n  varbo.minimize(q, SP, budget=100000, seed=1)\n  raise AssertionError('finished')\nexcept KeyboardInterrupt: pass\n"
      "assert time.time()-t < 15, time.time()-t", None)
probe("E", "SIGINT during Study.ask (bo, long)",
      "s=mk('k.db','task: {type: hartmann6}\\nbudget: 300\\nseed: 1\\n'); x=[s.tell(t, float(i)) for i,t in enumerate(s.ask(60))]\n"
      "threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT)).start(); t=time.time()\n"
      "try:\n  for _ in range(200):\n    for tr in s.ask(): s.tell(tr, 1.0)\n  raise AssertionError('no interrupt')\nexcept KeyboardInterrupt: pass\nassert time.time()-t < 10, time.time()-t", None)
probe("E", "other threads run during minimize (GIL released)",
      "cnt=[0]; stop=[False]\ndef spin():\n  while not stop[0]: cnt[0]+=1; time.sleep(0.001)\n"
      "th=threading.Thread(target=spin); th.start(); varbo.minimize(q, SP, budget=15, seed=1); stop[0]=True; th.join(); assert cnt[0]>50, cnt", None)
probe("E", "minimize from 2 threads at once",
      "res={}\ndef w(i): res[i]=varbo.minimize(q, SP, budget=8, seed=3)\nth=[threading.Thread(target=w, args=(i,)) for i in range(2)]\n"
      "[x.start() for x in th]; [x.join() for x in th]\nassert [tuple(t.x) for t in res[0].trials]==[tuple(t.x) for t in res[1].trials]", None)
probe("E", "del Study while a thread uses it",
      "s=mk('g.db', 'task: {type: branin}\\nbudget: 200\\nseed: 1\\nalgorithm: {type: random}\\n')\n"
      "def w(st):\n  for _ in range(50):\n    for t in st.ask(): st.tell(t, 1.0)\n"
      "th=threading.Thread(target=w, args=(s,)); th.start(); del s; import gc; gc.collect(); th.join()", None)

probe("E", "sys.exit inside fun -> SystemExit, study consistent",
      "o=os.path.join(T,'se')\ntry:\n  varbo.minimize(lambda p: sys.exit(3), SP, budget=4, seed=1, output=o)\nexcept SystemExit as e: assert e.code==3\n"
      "else: raise AssertionError('no SystemExit')\nst=[t.state for t in varbo.Study.open(o+'/study.db').trials(as_frame=False)]; assert 'pending' not in st, st", None)
probe("E", "callback raises KeyboardInterrupt", "varbo.minimize(q, SP, budget=4, seed=1, callback=lambda t: (_ for _ in ()).throw(KeyboardInterrupt()))", ("KeyboardInterrupt",), ())
probe("E", "Ctrl-C latency during slow bo asks (N=150, 6-D)",
      "s=mk('l.db','task: {type: hartmann6}\\nbudget: 400\\nseed: 1\\n'); [s.tell(t, float(i)) for i,t in enumerate(s.ask(150))]\n"
      "t0=time.time(); s.tell(s.ask()[0], 1.0); one=time.time()-t0\n"
      "threading.Timer(0.2, lambda: os.kill(os.getpid(), signal.SIGINT)).start(); t=time.time()\n"
      "try:\n  while True:\n    for tr in s.ask(): s.tell(tr, 1.0)\nexcept KeyboardInterrupt: pass\n"
      "lat=time.time()-t-0.2; print('one ask+tell', one, 'latency', lat); assert lat < max(3.0, 2*one), (one, lat)\n"
      "assert 'pending' not in [x.state for x in s.trials(as_frame=False)][:-1]", None)
probe("C", "progress='yes'", "varbo.minimize(q, SP, budget=2, seed=1, progress='yes')", ("TypeError",), ("minimize: progress",))
probe("C", "resume=1 (an int flag)", "o=os.path.join(T,'r1'); varbo.minimize(q, SP, budget=2, seed=1, output=o); r=varbo.minimize(q, SP, budget=3, seed=1, output=o, resume=1); assert r.evaluations==3", None)

# ---- F. objects: pickling, copying, lifecycle ----
probe("F", "pickle Study", "pickle.dumps(mk())", ("TypeError",), ("Study",))
probe("F", "deepcopy Study", "copy.deepcopy(mk())", ("TypeError",), ("Study",))
probe("F", "copy.copy Study", "s=mk(); c=copy.copy(s); c.tell(s.ask()[0], 1.0); assert s.best() is not None", None)
probe("F", "pickle Model", XY + "pickle.dumps(varbo.fit('gp', X, y, optimize=False))", ("TypeError",), ("Model",))
probe("F", "pickle Trial / OptimizeResult", "s=mk(); t=s.ask()[0]; pickle.loads(pickle.dumps(t))\nr=varbo.minimize(q, RND, **MIN); pickle.loads(pickle.dumps(r))", None)
probe("F", "Study after file deleted", "s=mk(); t=s.ask(2); s.tell(t[0], 1.0); os.remove(s.location); s.tell(t[1], 2.0)", ("InputError",), ("deleted",))
probe("F", "Study after file replaced", "s=mk(); t=s.ask(2); s.tell(t[0], 1.0); p=s.location; os.rename(p, p+'.old'); open(p, 'w').write('x')\ntry: s.tell(t[1], 2.0)\nfinally: assert open(p).read()=='x'", ("InputError",), ("replaced",))
probe("F", "create where an open study's file was moved away (its -wal left)",
      "s=mk(); t=s.ask(2); s.tell(t[0], 1.0); p=s.location; os.rename(p, p+'.old')\n"
      "try:\n  n=mk(); st=[x.state for x in n.trials(as_frame=False)]; assert st==[], st\nexcept varbo.InputError as e: assert '-wal' in str(e), e", None)
probe("F", "_Study() direct construction", "varbo._varbo._Study()", ("TypeError",), ())
probe("F", "Study(None)", "varbo.Study(None).ask()", ("TypeError",), ("Study",))

# ---- G. optuna ----
OPT = "import optuna, varbo.optuna\noptuna.logging.set_verbosity(optuna.logging.ERROR)\n"
probe("G", "VarboSampler unknown algorithm", OPT + "s=optuna.create_study(sampler=varbo.optuna.VarboSampler({'type': 'nosuch'}, seed=1))\n"
      "s.optimize(lambda t: t.suggest_float('x', 0, 1), n_trials=4)", ("UnknownComponentError",), ("nosuch",))
probe("G", "VarboSampler seed='a'", OPT + "varbo.optuna.VarboSampler(seed='a')", ("TypeError", "ValueError"), ("seed",))
probe("G", "VarboSampler seed=-1", OPT + "s=optuna.create_study(sampler=varbo.optuna.VarboSampler(seed=-1))\n"
      "s.optimize(lambda t: t.suggest_float('x', 0, 1), n_trials=4)", ("ValueError",), ("seed",))
probe("G", "VarboSampler float step + log-int + categorical None", OPT +
      "s=optuna.create_study(sampler=varbo.optuna.VarboSampler(seed=1))\n"
      "s.optimize(lambda t: t.suggest_float('x', 0, 1, step=0.1) + t.suggest_int('n', 1, 100, log=True) + (t.suggest_categorical('c', [None, 1.5, 'a']) is None), n_trials=8)", None)
probe("G", "VarboSampler objective returns NaN", OPT +
      "s=optuna.create_study(sampler=varbo.optuna.VarboSampler(seed=1))\n"
      "s.optimize(lambda t: float('nan') if t.number % 2 else t.suggest_float('x', 0, 1), n_trials=8)", None)
probe("G", "VarboSampler pickled", OPT + "pickle.loads(pickle.dumps(varbo.optuna.VarboSampler(seed=1)))", None)
probe("G", "VarboSampler threads=-1", OPT + "varbo.optuna.VarboSampler(seed=1, threads=-1)", ("ValueError",), ("threads",))

# ---- H. module functions and odd corners ----
probe("H", "ask(10**9) with budget 8", "s=mk(); assert len(s.ask(10**9))==8", None)
probe("H", "set_log_level('loud')", "varbo.set_log_level('loud')", ("ConfigError", "InputError", "ValueError"), ("loud",))
probe("H", "set_log_level(None)", "varbo.set_log_level(None)", ("TypeError",), ("level: expected",))
probe("H", "describe(None)", "varbo.describe(None)", ("TypeError",), ("name: expected",))
probe("H", "describe('')", "varbo.describe('')", ("UnknownComponentError", "ConfigError"), ())
probe("H", "plugins(123)", "varbo.plugins(123)", ("TypeError",), ("kind: expected",))
probe("H", "load_plugin(None)", "varbo.load_plugin(None)", ("TypeError",), ("path: expected",))
probe("H", "load_plugin(directory)", "varbo.load_plugin(T)", ("InputError", "PluginLoadError"), ("probe-",))
probe("H", "config path is a directory", "d=os.path.join(T,'c.yaml'); os.mkdir(d); mk('x.db', d)", ("InputError", "ConfigError"), ("c.yaml",))
probe("H", "fun returns dict cost 'abc'", "r=varbo.minimize(lambda p: {'cost': 'abc'}, RND, **MIN); assert r.failed==6 and 'abc' in r.trials[0].error", None)
probe("H", "fun returns dict components list", "r=varbo.minimize(lambda p: {'cost': 1.0, 'components': [1]}, RND, **MIN); assert r.failed==6 and 'components' in r.trials[0].error", None)
probe("H", "fun returns np.int64", "r=varbo.minimize(lambda p: np.int64(3), RND, **MIN); assert r.failed==0 and r.fun==3.0", None)
probe("H", "minimize into non-empty folder without overwrite", "o=os.path.join(T,'o'); varbo.minimize(q, SP, budget=2, seed=1, output=o)\nvarbo.minimize(q, SP, budget=2, seed=1, output=o)", ("InputError", "ConfigError"), ("o",))
probe("H", "callback calls minimize (re-entrant)", "r=varbo.minimize(q, SP, budget=3, seed=1, callback=lambda t: varbo.minimize(q, SP, budget=2, seed=2) and False); assert r.evaluations==3", None)
probe("H", "callback uses Study of the run", "r=varbo.minimize(q, SP, budget=3, seed=1, callback=lambda t: None); s=varbo.Study.open(r.output + '/study.db'); assert len(s.trials(as_frame=False))==3", None)
probe("H", "trials(as_frame=False) after minimize + tell_point", "r=varbo.minimize(q, SP, budget=3, seed=1); s=varbo.Study.open(r.output + '/study.db'); i=s.tell_point({'x': 0.1, 'y': 1.0}, 0.5); t=s.trials(as_frame=False)[-1]; assert t.id==i and t.phase=='manual' and t.cost==0.5", None)


def main():
    sel = sys.argv[1] if len(sys.argv) > 1 else ""
    env = dict(os.environ)
    results = []
    for cat, name, code, expect, words in P:
        if sel and sel not in name and sel != cat:
            continue
        child = PRE + "\ntry:\n" + "".join("    " + l + "\n" for l in code.splitlines()) + \
            "    print('@@OK')\nexcept BaseException as e:\n    import traceback\n" \
            "    print('@@EXC', type(e).__name__, '|'.join(c.__name__ for c in type(e).__mro__), repr(str(e))[:400])\n"
        t0 = time.time()
        try:
            r = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, timeout=90, env=env)
            out, rc = r.stdout + r.stderr, r.returncode
        except subprocess.TimeoutExpired:
            out, rc = "TIMEOUT", None
        dt = time.time() - t0
        line = next((l for l in out.splitlines() if l.startswith("@@")), "")
        ok = False
        if rc is None:
            what = "hang (timeout 90 s)"
        elif rc < 0:
            what = f"killed by signal {-rc}"
        elif line.startswith("@@OK"):
            ok = expect is None or None in expect
            what = "ran through" + ("" if ok else " (expected an exception)")
        elif line.startswith("@@EXC"):
            _, tname, mro, msg = line.split(" ", 3)
            classes = mro.split("|")
            ok = expect is not None and any(x in classes for x in expect if x) and all(w in msg for w in words)
            what = f"{tname}: {msg}"
        else:
            what = f"exit {rc}: {out[-300:]!r}"
        results.append((cat, ok))
        print(f"{'PASS' if ok else 'FAIL'} [{cat}] {name} ({dt:.1f}s): {what}", flush=True)
    cats = sorted({c for c, _ in results})
    for c in cats:
        n = sum(1 for x, _ in results if x == c)
        f = sum(1 for x, ok in results if x == c and not ok)
        print(f"category {c}: {n} probes, {f} failed")
    print(f"total: {len(results)} probes, {sum(1 for _, ok in results if not ok)} failed")


if __name__ == "__main__":
    main()

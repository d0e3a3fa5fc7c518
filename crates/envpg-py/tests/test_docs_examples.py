"""The Python examples of docs/python.md run as written, each as a script."""

import re
import subprocess
import sys

from conftest import ROOT


def test_every_python_example_of_the_guide_runs(tmp_path):
    text = (ROOT / "docs" / "python.md").read_text()
    found = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(found) == 3
    for i, code in enumerate(found):
        script = tmp_path / f"guide_example_{i}.py"
        script.write_text(code)
        done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, (code, done.stderr[-3000:])


def test_a_script_that_trains_at_import_is_stopped_not_multiplied(tmp_path):
    script = tmp_path / "unguarded.py"
    script.write_text(
        "import sys\n"
        f"sys.path.insert(0, {str(ROOT / 'crates' / 'envpg-py' / 'tests')!r})\n"
        "import envpg\n"
        "from queues_env import Queues\n"
        "class Mine(Queues):\n    pass\n"
        "envpg.train(Mine(), workers=1, iterations=5, polish_iterations=0, progress=False)\n"
    )
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert done.returncode != 0
    assert 'if __name__ == "__main__"' in done.stderr

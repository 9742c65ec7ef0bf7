"""Python side of planetwear, for users of the planetwear FMU through fmpy.

Installed into the project's virtual environment by scripts/setup.sh
(`pip install -e python`).
"""

# SPDX-License-Identifier: GPL-3.0-or-later
import os
import sys

# Importing the add-on's core/ here must leave no __pycache__ in the add-on's source folder.
sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

"""Setup for ble_latex: a latex (vent/ballast) balloon plugin for BLE."""

import pathlib

import setuptools

_HERE = pathlib.Path(__file__).parent

# Tested versions are pinned in constraints.txt (pip install -c constraints.txt).
# `tensorflow` (not tensorflow-cpu): BLE and tf-keras require the `tensorflow`
# distribution, so listing tensorflow-cpu would install both into the same
# folder. The Linux `tensorflow` wheel runs on CPU; no CUDA packages are pulled.
_INSTALL_REQUIRES = [
    'balloon-learning-environment==1.0.1',
    'dopamine-rl==4.0.9',
    'jax>=0.6',
    'jaxlib>=0.6',
    'flax',
    'optax',
    'tensorflow',
    'tf-keras',
    'tensorflow-probability',
    'tensorboard',
    'gym==0.25.2',
    'gymnasium>=1.0',
    'gin-config',
    'opensimplex',
    'scipy>=1.14',
    'numpy',
    'scikit-learn',
    'matplotlib',
    'xarray',
    'netCDF4',
    # GRIB2 analyses (GFS) through xarray: cfgrib and ECMWF's eccodes wheels.
    'cfgrib',
    'eccodes',
    'cdsapi',
    'tqdm',
    # Launch planning's Bayesian optimiser (ble_latex.launch.search).
    'bayesian-optimization==3.4.0',
    # Coastlines of `ble-latex-plot`'s track map: GSHHG's distance to the
    # coast on a 0.1 deg grid, shipped in the wheel (ble_latex.plots.maps).
    'landmetrics==1.0.0',
]

setuptools.setup(
    name='ble_latex',
    version='0.1.0',
    description=('Latex high-altitude balloon (vent helium / drop sand) for '
                 "Google's Balloon Learning Environment, with SAC."),
    long_description=(_HERE / 'README.md').read_text(encoding='utf-8'),
    long_description_content_type='text/markdown',
    author='The ble_latex developers',
    license='Apache-2.0',
    license_files=['LICENSE'],
    project_urls={
        'Paper': 'https://arxiv.org/abs/2303.01173',
        'Balloon Learning Environment':
            'https://github.com/google/balloon-learning-environment',
    },
    keywords=['reinforcement learning', 'high-altitude balloon',
              'station-keeping', 'soft actor-critic', 'jax', 'gymnasium'],
    classifiers=[
        'Development Status :: 4 - Beta',
        'Intended Audience :: Science/Research',
        'Operating System :: POSIX :: Linux',
        'Programming Language :: Python :: 3',
        'Programming Language :: Python :: 3.11',
        'Topic :: Scientific/Engineering :: Artificial Intelligence',
        'Topic :: Scientific/Engineering :: Atmospheric Science',
    ],
    python_requires='>=3.11',
    packages=(setuptools.find_packages(include=['ble_latex', 'ble_latex.*']) +
              ['ble_latex.gin_configs']),
    # The top-level gin_configs/ folder installs as ble_latex/gin_configs.
    package_dir={'ble_latex.gin_configs': 'gin_configs'},
    package_data={'ble_latex.gin_configs': ['*.gin'],
                  'ble_latex.agents': ['policies/*.msgpack']},
    install_requires=_INSTALL_REQUIRES,
    extras_require={
        # SB3 and the CPU torch for tests/examples/test_sb3_sac.py and examples/.
        # zarr: tests/wind/test_era5_arco.py's local Zarr stores (no gcsfs).
        # lz4: RLlib's sample compression (examples/rllib_ppo.py; RLlib
        # warns without it).
        'test': ['pytest', 'pytest-timeout', 'pytest-xdist', 'hypothesis',
                 'stable-baselines3', 'torch', 'ray[tune]', 'zarr', 'lz4'],
        # ble-latex-download-era5 --source=arco (Google's ARCO-ERA5 store).
        'arco': ['zarr', 'gcsfs'],
        # ble-latex-eval --ray_address and ble-latex-sweep.
        'ray': ['ray[tune]'],
        # The documentation site (mkdocs.yml, docs/; tests/docs/test_docs.py builds
        # it with `mkdocs build --strict`).
        'docs': ['mkdocs', 'mkdocs-material', 'mkdocstrings[python]'],
    },
    entry_points={
        'gym.envs': [
            '__root__ = ble_latex.ble.gym_registration:register_env',
        ],
        'console_scripts': [
            'ble-latex-ble = ble_latex.cli.ble_commands:main',
            'ble-latex-validate = ble_latex.cli.validate:main',
            'ble-latex-train = ble_latex.cli.train:main',
            'ble-latex-eval = ble_latex.cli.eval:main',
            'ble-latex-download-era5 = ble_latex.cli.download_era5:main',
            'ble-latex-download-gfs = ble_latex.cli.download_gfs:main',
            'ble-latex-plot = ble_latex.cli.plot:main',
            'ble-latex-sweep = ble_latex.cli.sweep:main',
            'ble-latex-demo = ble_latex.cli.demo:main',
            'ble-latex-export-policy = ble_latex.cli.export_policy:main',
            'ble-latex-launch = ble_latex.cli.launch:main',
        ],
    },
)

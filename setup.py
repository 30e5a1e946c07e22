"""ament_python package set-up: works with colcon on a ROS 2 install and with pip in a venv."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'screwgear_ros'
EXECUTABLES = ['table_sim', 'demo_controller', 'check_run', 'replay_run', 'paper_report', 'plot_run',
               'run_scenario', 'linearize', 'frequency_response', 'sweep', 'warmup',
               'identify']

setup(
    name=PACKAGE,
    version='0.2.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/config', glob('config/*.yaml')),
        (f'share/{PACKAGE}/urdf', glob('urdf/*.urdf')),
        (f'share/{PACKAGE}/launch', glob('launch/*.launch.py')),
        # For `ros2 run` after a pip install: ament looks in $prefix/lib/<package>/.
        # A colcon install puts the console scripts themselves there (setup.cfg).
        (f'lib/{PACKAGE}', [f'launchers/{exe}' for exe in EXECUTABLES]),
    ],
    # The ranges of requirements.txt's runtime part; constraints.txt pins the tested set.
    install_requires=['setuptools', 'numpy>=1.26,<3', 'scipy>=1.11', 'numba>=0.59',
                      'PyYAML>=6', 'mcap>=1.2', 'zstandard>=0.21', 'mcap-ros2-support>=0.5',
                      'rosbags>=0.10', 'tqdm>=4', 'matplotlib>=3.8'],
    # pip install screwgear_ros[gym]: the Gymnasium environment (screwgear_ros.envs.table_env).
    # pip install screwgear_ros[sweep]: sweep on Dask (LocalCluster or a cluster), parquet.
    # pip install screwgear_ros[design]: linearize --format control (python-control).
    extras_require={'gym': ['gymnasium>=1.0'], 'design': ['control>=0.10'],
                    'sweep': ['dask[distributed]>=2024.1', 'pyarrow>=14']},
    zip_safe=True,
    maintainer='screwgear_ros developers',
    maintainer_email='screwgear-ros@example.org',
    description='Real-time double screw gear anti-backlash rotary table plant for ROS 2',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [
            f'{exe} = {PACKAGE}.cli.{exe}:main' for exe in EXECUTABLES
        ],
    },
)

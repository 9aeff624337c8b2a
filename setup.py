from glob import glob

from setuptools import find_packages, setup

package_name = 'pool_sim'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['msg_tests', 'benchmarks']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml', 'LICENSE']),
        ('share/' + package_name + '/config', glob('config/*.yaml') + glob('config/*.rviz')),
    ],
    # The core (pool_sim.physics) and the pytest plugin. Lower bounds: numba 0.60 is the
    # first release on numpy 2; requirements.txt pins the versions the tests run
    # (numpy 2.4.6, numba 0.68.1, PyYAML 6.0.3). The ROS 2 wheels stay in requirements.txt:
    # on PyPI they go by other names than a ROS install's, which pip would not see.
    install_requires=['numpy>=2.0', 'numba>=0.60', 'PyYAML>=6.0'],
    extras_require={
        'record': ['mcap>=1.6.0,<2'],  # the node's `record`, headless --record
        'view': ['foxglove-sdk>=0.30.3,<0.31'],  # foxglove_port, headless --foxglove
        'picture': ['matplotlib>=3.8'],  # headless --animate
        # backend: cuda (docs/gpu.md); its CUDA toolkit wheels are ~450 MB, so not in run's.
        'cuda': ['numba-cuda[cu13]>=0.30.4,<0.31'],
    },
    python_requires='>=3.11',
    zip_safe=True,
    maintainer='pool_sim maintainers',
    maintainer_email='pool_sim@example.com',
    description='Spheres falling through air into a pool of water, as a ROS 2 node.',
    license='Apache-2.0',
    license_files=['LICENSE'],
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            # Through executables.py, which takes SIGINT and SIGTERM before any heavy import.
            'pool_sim = pool_sim.ros.executables:pool_sim',
            'depth_keeper = pool_sim.ros.executables:depth_keeper',
            # As `python -m pool_sim.headless`: no node to stop cleanly; headless takes SIGINT
            # and SIGTERM itself where a file must be finished (--record, --foxglove).
            'pool_sim_headless = pool_sim.headless:main',
        ],
        # pytest finds pool_sim.testing's fixture by itself once pool_sim is installed.
        'pytest11': ['pool_sim = pool_sim.testing'],
    },
)

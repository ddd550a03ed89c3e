"""studies table, jobs.study_id and jobs.study_point

Revision ID: 0002
Revises: 0001
"""

from alembic import op
import sqlalchemy as sa


revision = '0002'
down_revision = '0001'
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table('studies',
    sa.Column('seq', sa.Integer(), autoincrement=True, nullable=False),
    sa.Column('id', sa.String(length=32), nullable=False),
    sa.Column('owner', sa.String(length=64), nullable=False),
    sa.Column('name', sa.String(length=200), nullable=False),
    sa.Column('spec', sa.JSON(), nullable=False),
    sa.Column('plan', sa.JSON(), nullable=False),
    sa.Column('points', sa.Integer(), nullable=False),
    sa.Column('cancel_requested', sa.Boolean(), nullable=False),
    sa.Column('created_at', sa.DateTime(timezone=True), nullable=False),
    sa.PrimaryKeyConstraint('seq'),
    sa.UniqueConstraint('id')
    )
    op.create_index('ix_studies_owner_seq', 'studies', ['owner', 'seq'], unique=False)
    with op.batch_alter_table('jobs', schema=None) as batch_op:
        batch_op.add_column(sa.Column('study_id', sa.String(length=32), nullable=True))
        batch_op.add_column(sa.Column('study_point', sa.Integer(), nullable=True))
        batch_op.create_index(batch_op.f('ix_jobs_study_id'), ['study_id'], unique=False)
        batch_op.create_foreign_key('fk_jobs_study_id_studies', 'studies', ['study_id'], ['id'])


def downgrade() -> None:
    with op.batch_alter_table('jobs', schema=None) as batch_op:
        batch_op.drop_constraint('fk_jobs_study_id_studies', type_='foreignkey')
        batch_op.drop_index(batch_op.f('ix_jobs_study_id'))
        batch_op.drop_column('study_point')
        batch_op.drop_column('study_id')
    op.drop_index('ix_studies_owner_seq', table_name='studies')
    op.drop_table('studies')

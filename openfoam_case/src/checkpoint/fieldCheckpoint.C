/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | TunnelQuake: water side, built against
   \\    /   O peration     | OpenFOAM v1912
    \\  /    A nd           |
     \\/     M anipulation  |
-------------------------------------------------------------------------------
License
    GPL-3.0-or-later, like the OpenFOAM libraries it links against.

\*---------------------------------------------------------------------------*/

#include "fieldCheckpoint.H"
#include "volFields.H"
#include "surfaceFields.H"
#include "pointFields.H"
#include "valuePointPatchField.H"
#include "tqProjected.H"

#include <algorithm>

// * * * * * * * * * * * * * * * Local Functions * * * * * * * * * * * * * * //

namespace Foam
{
namespace tq
{
namespace
{

// Storage behind a patch field, or nullptr where the patch type holds none.
// fv and fvs patch fields are Fields; point patch fields only when they hold
// values (fixedValue and the like).

template<class Type>
Field<Type>* patchStorage(fvPatchField<Type>& pf)
{
    return &pf;
}

template<class Type>
Field<Type>* patchStorage(fvsPatchField<Type>& pf)
{
    return &pf;
}

template<class Type>
Field<Type>* patchStorage(pointPatchField<Type>& pf)
{
    return dynamic_cast<valuePointPatchField<Type>*>(&pf);
}


//- A saved GeometricField: internal and boundary values
template<class GeoField>
class savedGeoField
:
    public savedObject
{
    typedef typename GeoField::value_type Type;

    word name_;
    Field<Type> internal_;
    List<Field<Type>> patches_;
    boolList hasPatch_;

public:

    explicit savedGeoField(const GeoField& fld)
    :
        name_(fld.name()),
        internal_(),
        patches_(),
        hasPatch_()
    {
        copy(fld);
    }

    //- Take the current values of fld (the same field, or a new one of the
    //  same name); storage of unchanged size is reused, not reallocated
    void copy(const GeoField& fld)
    {
        internal_ = fld.primitiveField();

        // Read the boundary without triggering the old-time bookkeeping
        GeoField& f = const_cast<GeoField&>(fld);
        auto& bf = f.boundaryFieldRef(false);
        patches_.setSize(bf.size());
        hasPatch_.setSize(bf.size());
        forAll(bf, patchi)
        {
            const Field<Type>* s = patchStorage(bf[patchi]);
            hasPatch_[patchi] = bool(s);
            if (s)
            {
                patches_[patchi] = *s;
            }
            else
            {
                patches_[patchi].clear();
            }
        }
    }

    virtual const word& name() const
    {
        return name_;
    }

    virtual bool restore(const objectRegistry& obr) const
    {
        GeoField* fldPtr = obr.getObjectPtr<GeoField>(name_);
        if (!fldPtr)
        {
            return false;
        }
        GeoField& fld = *fldPtr;

        // Raw copies: 'false' keeps OpenFOAM from storing old-time levels
        // at this (unchanged) time index.
        fld.primitiveFieldRef(false) = internal_;
        auto& bf = fld.boundaryFieldRef(false);
        forAll(bf, patchi)
        {
            Field<Type>* s = patchStorage(bf[patchi]);
            if (s && hasPatch_[patchi])
            {
                *s = patches_[patchi];
            }
        }
        return true;
    }
};


//- A saved projection basis of the tqProjected linear solver
class savedProjection
:
    public savedObject
{
    word name_;
    scalar sign_;
    std::vector<scalarField> q_;

public:

    explicit savedProjection(const projectionHistory& h)
    :
        name_(h.name())
    {
        copy(h);
    }

    void copy(const projectionHistory& h)
    {
        sign_ = h.sign;
        q_ = h.q;
    }

    virtual const word& name() const
    {
        return name_;
    }

    virtual bool restore(const objectRegistry& obr) const
    {
        projectionHistory* h = obr.getObjectPtr<projectionHistory>(name_);
        if (!h)
        {
            return false;
        }
        h->sign = sign_;
        h->q = q_;
        return true;
    }
};

} // End anonymous namespace
} // End namespace tq
} // End namespace Foam


// * * * * * * * * * * * * * * Static Data Members * * * * * * * * * * * * * //

namespace Foam
{
namespace tq
{
    defineTypeNameAndDebug(fieldCheckpoint, 0);
}
}


// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

template<class Object, class Saved>
bool Foam::tq::fieldCheckpoint::storeObject
(
    const regIOobject& obj,
    std::vector<bool>& seen
)
{
    const Object* fldPtr = dynamic_cast<const Object*>(&obj);
    if (!fldPtr)
    {
        return false;
    }

    // Saved before under this name and type: copy into that storage
    const auto iter = slots_.cfind(obj.name());
    if (iter.found())
    {
        Saved* s = dynamic_cast<Saved*>(&fields_[*iter]);
        if (s)
        {
            s->copy(*fldPtr);
            seen[*iter] = true;
            return true;
        }
        fields_.set(*iter, new Saved(*fldPtr));
        seen[*iter] = true;
        return true;
    }

    const label slot = fields_.size();
    fields_.append(new Saved(*fldPtr));
    slots_.set(obj.name(), slot);
    seen.resize(slot + 1, false);
    seen[slot] = true;
    return true;
}


template<class GeoField>
bool Foam::tq::fieldCheckpoint::storeField
(
    const regIOobject& obj,
    std::vector<bool>& seen
)
{
    return storeObject<GeoField, savedGeoField<GeoField>>(obj, seen);
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::tq::fieldCheckpoint::fieldCheckpoint(const fvMesh& mesh)
:
    mesh_(mesh),
    valid_(false),
    time_(0),
    deltaT_(0),
    timeIndex_(-1),
    fields_(),
    slots_(),
    moving_(false)
{}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void Foam::tq::fieldCheckpoint::store()
{
    const Time& runTime = mesh_.time();
    time_ = runTime.value();
    deltaT_ = runTime.deltaTValue();
    timeIndex_ = runTime.timeIndex();

    // Every registered field of the saved types, in one pass over the
    // registry.  A field saved at the previous store is copied into its
    // storage (a coupled run stores every window: allocating and looking up
    // each field by type anew cost 0.1 ms a window on the 336-cell slice);
    // fields that no longer exist are dropped, new ones added.
    std::vector<bool> seen(fields_.size(), false);
    forAllConstIters(mesh_.thisDb(), iter)
    {
        const regIOobject& obj = *iter.val();
        storeField<volScalarField>(obj, seen)
     || storeField<volVectorField>(obj, seen)
     || storeField<volSymmTensorField>(obj, seen)
     || storeField<volTensorField>(obj, seen)
     || storeField<surfaceScalarField>(obj, seen)
     || storeField<surfaceVectorField>(obj, seen)
     || storeField<surfaceSymmTensorField>(obj, seen)
     || storeField<surfaceTensorField>(obj, seen)
     || storeField<pointScalarField>(obj, seen)
     || storeField<pointVectorField>(obj, seen)
     || storeObject<projectionHistory, savedProjection>(obj, seen);
    }
    if (std::find(seen.begin(), seen.end(), false) != seen.end())
    {
        PtrList<savedObject> kept(fields_.size());
        slots_.clear();
        label n = 0;
        forAll(fields_, i)
        {
            if (seen[i])
            {
                slots_.set(fields_[i].name(), n);
                kept.set
                (
                    n++,
                    fields_.set(i, static_cast<savedObject*>(nullptr))
                );
            }
        }
        kept.setSize(n);
        fields_.transfer(kept);
    }

    // Mesh motion state.  V0 and meshPhi exist once the mesh has moved.
    points_ = mesh_.points();
    moving_ = mesh_.moving() && runTime.timeIndex() > runTime.startTimeIndex();
    if (moving_)
    {
        fvMesh& mesh = const_cast<fvMesh&>(mesh_);
        V0_ = mesh.setV0();

        surfaceScalarField& meshPhi = mesh.setPhi();
        meshPhi_ = meshPhi.primitiveField();
        const auto& bf = meshPhi.boundaryFieldRef(false);
        meshPhiBf_.setSize(bf.size());
        forAll(bf, patchi)
        {
            meshPhiBf_[patchi] = bf[patchi];
        }

        // meshPhi_0: at this time index its access stores nothing
        const surfaceScalarField& meshPhi0 = meshPhi.oldTime();
        meshPhi0_ = meshPhi0.primitiveField();
        meshPhi0Bf_.setSize(bf.size());
        forAll(bf, patchi)
        {
            meshPhi0Bf_[patchi] = meshPhi0.boundaryField()[patchi];
        }
    }

    valid_ = true;

    if (debug)
    {
        Info<< "tq::fieldCheckpoint: stored " << fields_.size()
            << " fields at time " << time_ << endl;
    }
}


void Foam::tq::fieldCheckpoint::restore() const
{
    if (!valid_)
    {
        FatalErrorInFunction
            << "No checkpoint to restore: the partner asked for a rollback"
            << " before any state was saved (the exchange must ask for"
            << " writing a checkpoint first)." << exit(FatalError);
    }

    Time& runTime = const_cast<Time&>(mesh_.time());
    if (mag(runTime.deltaTValue() - deltaT_) > 1e-12*deltaT_)
    {
        FatalErrorInFunction
            << "Rollback with a changed time step (" << runTime.deltaTValue()
            << " s now, " << deltaT_ << " s when saved) is not supported."
            << nl << "Fix: use a fixed deltaT in coupled runs."
            << exit(FatalError);
    }

    // Time value back, step index kept increasing (see class description)
    runTime.setTime(time_, runTime.timeIndex());

    fvMesh& mesh = const_cast<fvMesh&>(mesh_);
    if (moving_)
    {
        // Same time index as the last motion: moves without shifting V0,
        // oldPoints or meshPhi_0; the swept-volume fluxes it computes are
        // overwritten below.
        mesh.movePoints(points_);
        mesh.setV0().field() = V0_;

        surfaceScalarField& meshPhi = mesh.setPhi();
        meshPhi.primitiveFieldRef(false) = meshPhi_;
        auto& bf = meshPhi.boundaryFieldRef(false);
        forAll(bf, patchi)
        {
            static_cast<scalarField&>(bf[patchi]) = meshPhiBf_[patchi];
        }
        surfaceScalarField& meshPhi0 = meshPhi.oldTime();
        meshPhi0.primitiveFieldRef(false) = meshPhi0_;
        auto& bf0 = meshPhi0.boundaryFieldRef(false);
        forAll(bf0, patchi)
        {
            static_cast<scalarField&>(bf0[patchi]) = meshPhi0Bf_[patchi];
        }
    }
    else if (mesh_.moving())
    {
        // Saved before the mesh first moved: back to the points of the
        // saved state, mesh at rest (no motion flux).  The next step stores
        // the current volumes as V0, as a fresh first step does.
        mesh.movePoints(points_);
        surfaceScalarField& meshPhi = mesh.setPhi();
        meshPhi.primitiveFieldRef(false) = 0;
        for (auto& pf : meshPhi.boundaryFieldRef(false))
        {
            static_cast<scalarField&>(pf) = 0;
        }
    }

    forAll(fields_, i)
    {
        if (!fields_[i].restore(mesh_))
        {
            WarningInFunction
                << "Field " << fields_[i].name() << " saved at time "
                << time_ << " no longer exists; not restored." << endl;
        }
    }

    if (debug)
    {
        Info<< "tq::fieldCheckpoint: restored " << fields_.size()
            << " fields to time " << time_ << " (saved at index "
            << timeIndex_ << ")" << endl;
    }
}


// ************************************************************************* //
